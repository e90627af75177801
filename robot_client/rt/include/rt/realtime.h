#pragma once
/// @file Real-time setup of the calling thread: SCHED_FIFO, locked memory, CPU affinity and a
/// prefaulted stack. Every step that the system refuses (typically EPERM without
/// CAP_SYS_NICE / CAP_IPC_LOCK or rtprio/memlock limits, as in containers) becomes a warning in
/// the report, never an error: the loop then runs with normal priority.

#include <cstddef>
#include <string>
#include <vector>

namespace wj::rt {

/// What setupRealtime() should do.
struct RtSettings {
  bool fifo = true;                              ///< switch the thread to SCHED_FIFO
  int priority = 80;                             ///< SCHED_FIFO priority, 1..99
  bool lock_memory = true;                       ///< mlockall(MCL_CURRENT | MCL_FUTURE)
  int cpu = -1;                                  ///< pin the thread to this CPU; -1: no pinning
  std::size_t prefault_stack_bytes = 256 << 10;  ///< stack to touch once [bytes]; 0: none

  /// Throws std::invalid_argument naming the field: priority in [1, 99], cpu >= -1,
  /// prefault_stack_bytes <= 8 MiB.
  void validate() const;
};

/// Outcome of each step of setupRealtime(); a step not asked for counts as done.
struct RtSetupReport {
  bool fifo = false;                  ///< SCHED_FIFO at the priority is active
  bool memory_locked = false;         ///< mlockall succeeded
  bool affinity = false;              ///< pinned to the CPU
  bool stack_prefaulted = false;      ///< stack touched
  std::vector<std::string> warnings;  ///< one sentence per refused step, with the fix

  /// True if every step asked for succeeded.
  bool allOk() const { return fifo && memory_locked && affinity && stack_prefaulted; }
};

/// Applies `settings` to the calling thread (validates them first; throws only for invalid
/// settings). Call once at the start of the loop thread, before its first period.
RtSetupReport setupRealtime(const RtSettings& settings);

}  // namespace wj::rt
