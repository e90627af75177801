#include "rt/realtime.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace wj::rt {
namespace {

std::string errnoText(int err) {
  const char* name = err == EPERM    ? "EPERM"
                     : err == EINVAL ? "EINVAL"
                     : err == ENOMEM ? "ENOMEM"
                                     : "";
  std::string s = std::strerror(err);
  if (*name != '\0') s = std::string(name) + ": " + s;
  return s;
}

// Touches `bytes` of stack below the caller so that the pages are mapped (and, after
// mlockall, locked) before the loop needs them.
[[gnu::noinline]] void prefaultStack(std::size_t bytes) {
  constexpr std::size_t kChunk = 16 << 10;
  volatile unsigned char buffer[kChunk];
  for (std::size_t i = 0; i < kChunk; i += 4096) buffer[i] = 0;
  asm volatile("" : : "r"(buffer) : "memory");  // keep the writes
  if (bytes > kChunk) prefaultStack(bytes - kChunk);
}

}  // namespace

void RtSettings::validate() const {
  if (fifo && (priority < 1 || priority > 99))
    throw std::invalid_argument("RtSettings.priority must be in [1, 99], got " +
                                std::to_string(priority));
  if (cpu < -1)
    throw std::invalid_argument("RtSettings.cpu must be >= -1 (-1: no pinning), got " +
                                std::to_string(cpu));
  if (prefault_stack_bytes > (8u << 20))
    throw std::invalid_argument("RtSettings.prefault_stack_bytes must be in [0, 8388608], got " +
                                std::to_string(prefault_stack_bytes));
}

RtSetupReport setupRealtime(const RtSettings& settings) {
  settings.validate();
  RtSetupReport report;

  if (settings.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      report.memory_locked = true;
    } else {
      const int err = errno;
      report.warnings.push_back(
          "mlockall not permitted (" + errnoText(err) +
          "): run with CAP_IPC_LOCK or a sufficient memlock limit; pages may be swapped or "
          "faulted in during the loop");
    }
  } else {
    report.memory_locked = true;
  }

  if (settings.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<unsigned>(settings.cpu), &set);
    const int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    if (err == 0) {
      report.affinity = true;
    } else {
      report.warnings.push_back("CPU affinity to CPU " + std::to_string(settings.cpu) +
                                " refused (" + errnoText(err) +
                                "): the loop thread may migrate between CPUs");
    }
  } else {
    report.affinity = true;
  }

  if (settings.fifo) {
    sched_param param{};
    param.sched_priority = settings.priority;
    const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    if (err == 0) {
      report.fifo = true;
    } else if (err == EPERM) {
      report.warnings.push_back(
          "SCHED_FIFO not permitted (EPERM): run with CAP_SYS_NICE or an rtprio limit; the loop "
          "runs with normal priority");
    } else {
      report.warnings.push_back("SCHED_FIFO at priority " + std::to_string(settings.priority) +
                                " failed (" + errnoText(err) +
                                "); the loop runs with normal priority");
    }
  } else {
    report.fifo = true;
  }

  if (settings.prefault_stack_bytes > 0) prefaultStack(settings.prefault_stack_bytes);
  report.stack_prefaulted = true;
  return report;
}

}  // namespace wj::rt
