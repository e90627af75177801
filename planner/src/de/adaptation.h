#pragma once
/// @file Control of the DE parameters F and CR: fixed, jDE or SHADE. Private to the solver.

#include <memory>

#include "planner/de/differential_evolution.h"
#include "random.h"

namespace wj::planner::de {

/// Scale factor and crossover rate of one trial vector.
struct ControlParameters {
  double F = 0.5;
  double CR = 0.9;
};

/// Draws F and CR for each trial and learns from the selection outcome. Called serially only.
class ParameterControl {
 public:
  virtual ~ParameterControl() = default;
  /// F and CR for the trial vector of individual i in the current generation.
  virtual ControlParameters sample(int i, Random& rng) = 0;
  /// Reports the selection of individual i's trial: whether it replaced its parent, and by how
  /// much it lowered the cost (|f(u) - f(x)|, > 0 only for a strict improvement).
  virtual void select(int i, const ControlParameters& used, bool replaced, double improvement) = 0;
  /// Closes a generation (SHADE updates its memory here).
  virtual void endGeneration() {}
};

/// The parameter control that `settings.adaptation` names, for a population of size `np`.
std::unique_ptr<ParameterControl> makeParameterControl(const Settings& settings, int np);

}  // namespace wj::planner::de
