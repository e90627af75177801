// setupRealtime: never fatal; each refused step is reported with a reason.
#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>

#include "rt/realtime.h"

namespace wj::rt {
namespace {

TEST(Realtime, RefusedStepsAreWarningsNotErrors) {
  // In a thread of its own, so that SCHED_FIFO (if granted) does not outlive the test.
  RtSetupReport report;
  std::thread t([&] {
    RtSettings s;
    s.cpu = 0;
    report = setupRealtime(s);
  });
  t.join();
  EXPECT_TRUE(report.stack_prefaulted);
  const int refused = !report.fifo + !report.memory_locked + !report.affinity;
  EXPECT_EQ(report.warnings.size(), static_cast<std::size_t>(refused));
  if (!report.fifo) {
    bool mentions_fifo = false;
    for (const auto& w : report.warnings) mentions_fifo |= w.find("SCHED_FIFO") != w.npos;
    EXPECT_TRUE(mentions_fifo);
  }
  for (const auto& w : report.warnings) std::cout << "[ warning  ] " << w << "\n";
}

TEST(Realtime, NothingAskedIsAllOk) {
  RtSettings s;
  s.fifo = false;
  s.lock_memory = false;
  s.prefault_stack_bytes = 0;
  const RtSetupReport report = setupRealtime(s);
  EXPECT_TRUE(report.allOk());
  EXPECT_TRUE(report.warnings.empty());
}

TEST(Realtime, ValidatesSettings) {
  RtSettings s;
  s.priority = 0;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  s.priority = 50;
  s.cpu = -2;
  EXPECT_THROW(setupRealtime(s), std::invalid_argument);
}

}  // namespace
}  // namespace wj::rt
