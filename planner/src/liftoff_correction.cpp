#include "planner/liftoff_correction.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace wj::planner {

namespace {

void requireWithin(const char* field, double value, double bound) {
  if (std::isfinite(value) && std::abs(value) <= bound) return;
  std::ostringstream ss;
  ss << "liftoff_correction." << field << " must be finite and in [" << -bound << ", " << bound
     << "], got " << value;
  throw std::invalid_argument(ss.str());
}

}  // namespace

void LiftOffCorrection::validate() const {
  requireWithin("vx", vx, kMaxVelocity);
  requireWithin("vz", vz, kMaxVelocity);
  requireWithin("momentum", momentum, kMaxMomentum);
}

LiftOffCorrection liftOffResidual(const JumpPlan& plan, const JumpEvent& measured_takeoff,
                                  double gravity) {
  const JumpEvent& p = plan.predicted.takeoff;
  const JumpEvent& m = measured_takeoff;
  LiftOffCorrection r;
  r.vx = m.state.vx - p.state.vx;
  r.vz = m.state.vz - (p.state.vz - gravity * (m.t - p.t));
  r.momentum = m.momentum - p.momentum;
  return r;
}

double liftOffResidualRatio(const JumpPlan& plan, const LiftOffCorrection& residual,
                            double velocity_tolerance, double momentum_tolerance) {
  const PlanarState& s = plan.predicted.takeoff.state;
  const double speed = std::max(std::hypot(s.vx, s.vz), 0.1);
  return std::max(std::hypot(residual.vx, residual.vz) / (velocity_tolerance * speed),
                  std::abs(residual.momentum) / momentum_tolerance);
}

LiftOffCorrection nextCorrection(const LiftOffCorrection& correction,
                                 const LiftOffCorrection& residual) {
  return {correction.vx + residual.vx, correction.vz + residual.vz,
          correction.momentum + residual.momentum};
}

bool withinBounds(const LiftOffCorrection& c) {
  using C = LiftOffCorrection;
  return std::abs(c.vx) <= C::kMaxVelocity && std::abs(c.vz) <= C::kMaxVelocity &&
         std::abs(c.momentum) <= C::kMaxMomentum;
}

}  // namespace wj::planner
