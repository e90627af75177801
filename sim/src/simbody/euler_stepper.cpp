#include "euler_stepper.h"

#include <stdexcept>

namespace wj::sim::detail {

namespace {

// The elements of a State's q, u or udot (views with unit stride into its continuous state).
const double* data(const SimTK::Vector& v) {
  if (!v.hasContiguousData()) throw std::logic_error("EulerStepper: a state vector has gaps");
  return v.getContiguousScalarData();
}

}  // namespace

bool EulerStepper::applies(const SimTK::MultibodySystem& system, const SimTK::State& state) {
  SimTK::State s = state;
  system.realize(s, SimTK::Stage::Instance);
  const SimTK::SimbodyMatterSubsystem& matter = system.getMatterSubsystem();
  return matter.getNumConstraints() == 0 && matter.getNumQuaternionsInUse(s) == 0 &&
         s.getNZ() == 0 && s.getNEventTriggers() == 0;
}

EulerStepper::EulerStepper(const SimTK::MultibodySystem& system, double max_step_s, bool qdot_is_u)
    : system_(system), h_(max_step_s), qdot_is_u_(qdot_is_u) {
  if (!(h_ > 0.0)) throw std::invalid_argument("EulerStepper: the step must be positive");
}

void EulerStepper::initialize(const SimTK::State& state) {
  state_ = state;
  if (qdot_is_u_ && state_.getNQ() != state_.getNU())
    throw std::logic_error("EulerStepper: qdot = u needs as many q as u");
  u1_.resize(state_.getNU());
  q1_.resize(state_.getNQ());
  qdot_.resize(state_.getNQ());
  system_.realize(state_, SimTK::Stage::Acceleration);
  ++realizations_;
}

void EulerStepper::stepTo(double t_end) {
  while (state_.getTime() < t_end) {
    const double t0 = state_.getTime();
    // AbstractIntegratorRep::takeOneStep's choice with interpolation off (tMax = t_end).
    double t1 = t_end;
    if (!(t_end < t0 + 0.95 * h_) && t_end > t0 + 1.001 * h_) t1 = t0 + h_;
    if (!(t1 > t0)) throw std::runtime_error("EulerStepper: unable to advance time");
    step(t1);
  }
}

void EulerStepper::step(double t1) {
  SimTK::State& s = state_;
  // Derivatives at the start of the step, with the forces (commands) in force now.
  if (s.getSystemStage() < SimTK::Stage::Acceleration) {
    system_.realize(s, SimTK::Stage::Acceleration);
    ++realizations_;
  }
  const double h = t1 - s.getTime();
  const int nu = s.getNU(), nq = s.getNQ();
  {
    const double* u0 = data(s.getU());
    const double* udot0 = data(s.getUDot());
    double* u1 = u1_.updContiguousScalarData();
    for (int i = 0; i < nu; ++i) u1[i] = u0[i] + h * udot0[i];
  }
  // qdot = N(q0) u1 (the position kinematics of q0 are still valid here); N = I exactly when
  // every mobilizer's qdot is its u.
  if (!qdot_is_u_) system_.multiplyByN(s, u1_, qdot_);
  {
    const double* q0 = data(s.getQ());
    const double* qdot = qdot_is_u_ ? u1_.getContiguousScalarData() : data(qdot_);
    double* q1 = q1_.updContiguousScalarData();
    for (int i = 0; i < nq; ++i) q1[i] = q0[i] + h * qdot[i];
  }
  s.setTime(t1);
  s.updU() = u1_;
  s.updQ() = q1_;
  ++steps_;
}

}  // namespace wj::sim::detail
