#pragma once
/// @file The NMPC's nonlinear program solved by Ipopt (interior point, MUMPS), as a reference
/// for the SQP: the same transcription (nodes, integrator, cost with relaxed barriers, dynamics
/// defects and state-input equalities), exact first derivatives from the same analytic
/// Jacobians, and a limited-memory quasi-Newton Hessian. Offline use only (tests, benchmark);
/// library target wj::nmpc_ipopt, separate from the real-time wj::nmpc.

#include <cstdint>
#include <string>
#include <vector>

#include "nmpc/problem.h"
#include "nmpc/sqp_solver.h"

namespace wj::nmpc {

/// Hessian of the Lagrangian given to Ipopt.
enum class IpoptHessian : std::uint8_t {
  FiniteDifference,  ///< exact cost Hessian + multiplier-weighted constraint curvature (FD)
  GaussNewton,       ///< the cost Hessian only, as the SQP uses
  LimitedMemory,     ///< Ipopt's L-BFGS approximation
};

/// Settings of the Ipopt reference solve.
struct IpoptReferenceSettings {
  IpoptHessian hessian = IpoptHessian::FiniteDifference;  ///< see IpoptHessian
  double tolerance = 1e-9;    ///< Ipopt "tol": scaled KKT error at convergence
  int max_iterations = 5000;  ///< Ipopt "max_iter"
  int lbfgs_memory = 30;      ///< pairs kept by the limited-memory Hessian approximation
  int print_level = 0;        ///< Ipopt "print_level" (0: silent, 5: per iteration)
};

/// Outcome of an Ipopt reference solve.
struct IpoptReferenceResult {
  bool solved = false;     ///< Ipopt reported Solve_Succeeded
  std::string status;      ///< Ipopt's return status, e.g. "Solve_Succeeded"
  int iterations = 0;      ///< Ipopt iterations
  double cost = 0.0;       ///< objective at the solution
  double violation = 0.0;  ///< 2-norm of defects and equalities at the solution
  double solve_ms = 0.0;   ///< wall time of OptimizeTNLP [ms]
  std::vector<State> x;    ///< N + 1 node states
  std::vector<Input> u;    ///< N node inputs
};

/// Solves the NLP that `solver` solves at (t0, x0, targets) (its settings define the grid and
/// the integrator; its problem the cost and constraints) with Ipopt, starting from x0 held
/// over the horizon and the weight-sharing input (as a cold SQP start). Thread-safe: solves
/// are serialised (the sequential MUMPS keeps global state).
IpoptReferenceResult solveWithIpopt(const SqpSettings& sqp_settings, const CentroidalOcp& problem,
                                    double t0, const State& x0, const Targets& targets,
                                    const IpoptReferenceSettings& settings = {});

}  // namespace wj::nmpc
