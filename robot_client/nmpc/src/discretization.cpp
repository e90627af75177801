#include "nmpc/discretization.h"

namespace wj::nmpc {

std::string_view toString(Integrator integrator) {
  switch (integrator) {
    case Integrator::ForwardEuler:
      return "forward_euler";
    case Integrator::RungeKutta4:
      return "runge_kutta4";
  }
  return "?";
}

void calcDiscreteDynamics(const CentroidalModel& model, Integrator integrator, const State& x,
                          const Input& u, const Eigen::Vector3d& n, double dt,
                          const ModelData& data_x, ModelData& scratch, State& x_next) {
  State k1;
  model.calcFlowMap(x, u, n, data_x, k1);
  if (integrator == Integrator::ForwardEuler) {
    x_next = x + dt * k1;
    return;
  }
  State k2, k3, k4, xs;
  xs = x + 0.5 * dt * k1;
  model.updateData(xs, scratch);
  model.calcFlowMap(xs, u, n, scratch, k2);
  xs = x + 0.5 * dt * k2;
  model.updateData(xs, scratch);
  model.calcFlowMap(xs, u, n, scratch, k3);
  xs = x + dt * k3;
  model.updateData(xs, scratch);
  model.calcFlowMap(xs, u, n, scratch, k4);
  x_next = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

void calcDiscreteDynamicsJacobians(const CentroidalModel& model, Integrator integrator,
                                   const State& x, const Input& u, const Eigen::Vector3d& n,
                                   double dt, const ModelData& data_x, ModelData& scratch,
                                   State& x_next, StateMatrix& A, StateInputMatrix& B) {
  State k1;
  StateMatrix A1;
  StateInputMatrix B1;
  model.calcFlowMapJacobians(x, u, n, data_x, k1, A1, B1);
  if (integrator == Integrator::ForwardEuler) {
    x_next = x + dt * k1;
    A = StateMatrix::Identity() + dt * A1;
    B = dt * B1;
    return;
  }
  // Stage i: k_i = f(x + c_i dt k_{i-1}, u); dk_i/dx = A_i (I + c_i dt dk_{i-1}/dx),
  // dk_i/du = A_i c_i dt dk_{i-1}/du + B_i.
  State k = k1, sum = k1;
  StateMatrix dk_dx = A1, sum_dx = A1, Ai;
  StateInputMatrix dk_du = B1, sum_du = B1, Bi;
  const double c[3] = {0.5, 0.5, 1.0};
  const double w[3] = {2.0, 2.0, 1.0};
  for (int s = 0; s < 3; ++s) {
    const State xs = x + c[s] * dt * k;
    model.updateData(xs, scratch);
    model.calcFlowMapJacobians(xs, u, n, scratch, k, Ai, Bi);
    const StateMatrix dxs_dx = StateMatrix::Identity() + c[s] * dt * dk_dx;
    dk_du = Ai * (c[s] * dt * dk_du) + Bi;
    dk_dx = Ai * dxs_dx;
    sum += w[s] * k;
    sum_dx += w[s] * dk_dx;
    sum_du += w[s] * dk_du;
  }
  x_next = x + dt / 6.0 * sum;
  A = StateMatrix::Identity() + dt / 6.0 * sum_dx;
  B = dt / 6.0 * sum_du;
}

}  // namespace wj::nmpc
