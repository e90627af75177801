// bench_timer: runs PeriodicTimer with an empty body and prints, as JSON, the wake-up lateness
// (wake-up time - deadline) and the period jitter (|actual period - nominal|): p50, p99, max
// [µs], overruns. The baseline of the full control loop's jitter benchmark.
#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>

#include "rt/loop_stats.h"
#include "rt/periodic_timer.h"
#include "rt/realtime.h"

int main(int argc, char** argv) {
  CLI::App app{"Wake-up lateness of an empty periodic loop (JSON on stdout)"};
  double seconds = 5.0;
  double period_us = 1000.0;
  bool realtime = true;
  int cpu = -1;
  app.add_option("--seconds", seconds, "duration [s]")->check(CLI::Range(0.01, 3600.0));
  app.add_option("--period-us", period_us, "loop period [us]")->check(CLI::Range(10.0, 1e6));
  app.add_option("--realtime", realtime, "try SCHED_FIFO + mlockall (warns if refused)");
  app.add_option("--cpu", cpu, "pin to this CPU (-1: no pinning)")->check(CLI::Range(-1, 1023));
  CLI11_PARSE(app, argc, argv);

  wj::rt::RtSetupReport rt_report;
  if (realtime) {
    wj::rt::RtSettings rt;
    rt.cpu = cpu;
    rt_report = wj::rt::setupRealtime(rt);
    for (const std::string& w : rt_report.warnings) std::cerr << "warning: " << w << "\n";
  }

  const auto period = std::chrono::nanoseconds(static_cast<long long>(period_us * 1e3));
  const auto iterations =
      static_cast<long long>(seconds * 1e9 / static_cast<double>(period.count()));
  wj::rt::PeriodicTimer timer(period);
  wj::rt::LoopStats lateness(period, 1.0, 20000);
  wj::rt::LoopStats jitter(period, 1.0, 20000);
  timer.start();
  for (long long k = 0; k < iterations; ++k) {
    const std::uint64_t overruns_before = timer.overruns();
    timer.waitNext();
    const bool overrun = timer.overruns() != overruns_before;
    const auto body = wj::rt::MonotonicClock::now() - timer.wakeTime();  // empty body
    lateness.record(timer.lateness(), body, overrun);
    if (k > 0) jitter.recordPeriod(timer.lastPeriod(), body, overrun);
  }

  nlohmann::json out;
  out["benchmark"] = "bench_timer";
  out["period_us"] = period_us;
  out["seconds"] = seconds;
  out["iterations"] = timer.iterations();
  out["overruns"] = timer.overruns();
  out["sched_fifo"] = rt_report.fifo && realtime;
  out["memory_locked"] = rt_report.memory_locked && realtime;
  out["lateness"] = lateness.toJson()["jitter"];
  out["period_jitter"] = jitter.toJson()["jitter"];
  std::cout << out.dump(2) << std::endl;
  return 0;
}
