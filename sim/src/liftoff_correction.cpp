#include "sim/liftoff_correction.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "planner/liftoff_correction.h"

namespace wj::sim {

namespace {

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

void requireRange(const char* field, double value, double lo, double hi, bool open) {
  const bool ok = std::isfinite(value) && (open ? value > lo : value >= lo) && value <= hi;
  if (ok) return;
  std::ostringstream ss;
  ss << "liftoff_correction." << field << " must be in " << (open ? "(" : "[") << lo << ", " << hi
     << "], got " << value;
  throw std::invalid_argument(ss.str());
}

// (verified, feasible, -residual_ratio): larger is better.
auto rank(const CorrectionRound& r) {
  return std::make_tuple(r.passed, r.feasible, -r.residual_ratio);
}

}  // namespace

void LiftOffCorrectionSettings::validate() const {
  requireRange("max_rounds", max_rounds, 0, 10, false);
  requireRange("velocity_tolerance", velocity_tolerance, 0.0, 1.0, true);
  requireRange("momentum_tolerance", momentum_tolerance, 0.0, 1.0, true);
}

planner::LiftOffCorrection measureLiftOffResidual(const planner::JumpPlan& plan,
                                                  const VerificationReport& report,
                                                  double gravity) {
  return planner::liftOffResidual(plan, report.measured.takeoff, gravity);
}

CorrectedPlan planWithLiftOffCorrection(const planner::JumpPlanner& planner,
                                        const VerifyPlan& verify, const planner::JumpTask& task,
                                        const planner::InitialState& initial,
                                        planner::PlanOptions options,
                                        const LiftOffCorrectionSettings& settings) {
  settings.validate();
  CorrectedPlan out;
  Eigen::VectorXd last_u;
  for (int round = 0; round <= settings.max_rounds; ++round) {
    const auto t_solve = std::chrono::steady_clock::now();
    planner::PlannerResult result = planner.plan(task, initial, options);
    CorrectionRound r;
    r.correction = options.liftoff_correction;
    r.solve_ms = msSince(t_solve);
    r.feasible = result.evaluation.feasible;
    VerificationReport report;
    if (result.evaluation.valid) {  // else there is no plan to verify
      const auto t_verify = std::chrono::steady_clock::now();
      report = verify(result.plan);
      r.verify_ms = msSince(t_verify);
      r.passed = report.passed;
      r.reasons = report.reasons;
    }
    const bool measured = report.took_off;
    if (measured) {
      r.residual = measureLiftOffResidual(result.plan, report, planner.settings().gravity);
      r.residual_ratio = planner::liftOffResidualRatio(
          result.plan, r.residual, settings.velocity_tolerance, settings.momentum_tolerance);
    } else {
      r.residual_ratio = std::numeric_limits<double>::infinity();
    }
    out.rounds.push_back(r);
    const bool better = out.rounds.size() == 1 || rank(r) > rank(out.rounds[out.chosen]);
    const Eigen::VectorXd this_u = result.u;
    if (better) {
      out.chosen = static_cast<int>(out.rounds.size()) - 1;
      out.result = std::move(result);
      out.report = std::move(report);
    }
    // A search that returns the last round's candidate again (an infeasible one may) repeats
    // its stance, and so Simbody's lift-off: another round would too.
    const bool repeated = last_u.size() == this_u.size() && last_u == this_u;
    if (!measured || repeated || (r.passed && r.feasible && r.residual_ratio <= 1.0)) break;
    const planner::LiftOffCorrection next = planner::nextCorrection(r.correction, r.residual);
    if (!planner::withinBounds(next)) break;
    options.liftoff_correction = next;
    options.warm_start = this_u;
    last_u = this_u;
  }
  return out;
}

}  // namespace wj::sim
