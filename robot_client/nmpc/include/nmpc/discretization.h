#pragma once
/// @file Discretisation of the flow map over one shooting interval with the input held
/// constant: x+ = F(x, u), and its sensitivities dF/dx, dF/du propagated through the stages.

#include <cstdint>
#include <string_view>

#include "nmpc/centroidal_model.h"

namespace wj::nmpc {

/// Explicit one-step integrators of the shooting intervals.
enum class Integrator : std::uint8_t {
  ForwardEuler,  ///< x + dt f(x, u): one flow-map evaluation, first order
  RungeKutta4,   ///< classic 4-stage Runge-Kutta: four evaluations, fourth order
};

/// "forward_euler", "runge_kutta4".
std::string_view toString(Integrator integrator);

/// One interval of length dt from x with input u held; `data_x` must be updated at x,
/// `scratch` is overwritten (intermediate stages).
void calcDiscreteDynamics(const CentroidalModel& model, Integrator integrator, const State& x,
                          const Input& u, const Eigen::Vector3d& n, double dt,
                          const ModelData& data_x, ModelData& scratch, State& x_next);

/// Same with the sensitivities A = dx+/dx, B = dx+/du.
void calcDiscreteDynamicsJacobians(const CentroidalModel& model, Integrator integrator,
                                   const State& x, const Input& u, const Eigen::Vector3d& n,
                                   double dt, const ModelData& data_x, ModelData& scratch,
                                   State& x_next, StateMatrix& A, StateInputMatrix& B);

}  // namespace wj::nmpc
