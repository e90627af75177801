#pragma once
// The fixed-step semi-explicit Euler method of SimTK::SemiExplicitEulerIntegrator, stepped here
// on a State of our own for systems where Simbody's integrator only adds bookkeeping: no
// constraints, no quaternions, no auxiliary (z) states, no event triggers, no prescribed
// motion (the sagittal model). Per step Simbody's integrator copies the state aside, realizes
// Position once at the old q and the new time only to apply N(q0) and its (empty)
// prescriptions, then at the new q, and checks (empty) constraint projections; this stepper
// realizes every stage once per step. The arithmetic is Simbody's, operation for operation:
//   u1 = u0 + h udot0,  q1 = q0 + h N(q0) u1,  t1 with Simbody's choice of the step end,
// so trajectories are the same bit for bit (tests/sim/test_euler_stepper.cpp).
//
// Internal to wj_sim_simbody (C++17, sees Simbody). The State setters used here are inline in
// Simbody's headers: they only match the installed library because this library is compiled
// with NDEBUG undefined, as Debian's Simbody is (sim/CMakeLists.txt).

#include <Simbody.h>

namespace wj::sim::detail {

class EulerStepper {
 public:
  /// True when `system` (its topology realized in `state`) has nothing the stepper leaves
  /// out: no constraints, quaternions, z states or event triggers. Prescribed motion is not
  /// looked for: SimRobot builds none.
  static bool applies(const SimTK::MultibodySystem& system, const SimTK::State& state);

  /// Fixed step `max_step_s` (SemiExplicitEulerIntegrator's). `qdot_is_u`: every mobilizer's
  /// kinematic matrix N is the identity (pins, the planar base), so qdot = u is used as is.
  EulerStepper(const SimTK::MultibodySystem& system, double max_step_s, bool qdot_is_u);

  /// Starts from `state` (copied) and realizes it through Acceleration.
  void initialize(const SimTK::State& state);
  /// Steps until `t_end` (at least one step): each step ends at t0 + h, or at t_end when that
  /// is within 0.95-1.001 h of t0 or closer, as Simbody's fixed-step integrator chooses.
  void stepTo(double t_end);

  const SimTK::State& getState() const { return state_; }
  SimTK::State& updState() { return state_; }
  double getTime() const { return state_.getTime(); }
  long stepsTaken() const { return steps_; }
  long realizations() const { return realizations_; }

 private:
  void step(double t1);

  const SimTK::MultibodySystem& system_;
  double h_;
  bool qdot_is_u_;
  SimTK::State state_;
  SimTK::Vector u1_, qdot_, q1_;  // per-step scratch, sized once
  long steps_ = 0;
  long realizations_ = 0;
};

}  // namespace wj::sim::detail
