#pragma once
/// @file The linear-quadratic subproblem of one SQP iteration: elimination of the state-input
/// equality constraints by projection onto the null space of their input Jacobian, and the
/// Riccati recursion on the projected problem (dense, on Eigen; fixed-capacity matrices, no
/// heap allocation).
///
/// Projection: g + C dx + D du = 0 with D (m x nu) of full row rank. With the QR factorisation
/// D^T = [Q1 Q2] [R1; 0], every solution is du = u0 + K dx + P dz with
///   u0 = -Q1 R1^-T g,  K = -Q1 R1^-T C,  P = Q2 (orthonormal basis of null(D)),
/// and dz the free reduced input (nu - m entries).

#include <Eigen/Core>
#include <vector>

#include "nmpc/problem.h"
#include "nmpc/types.h"

namespace wj::nmpc {

using ReducedVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kInputDim, 1>;
using ReducedMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kInputDim, kInputDim>;
/// Input from reduced input (nu x nz).
using ProjectionMatrix = Eigen::Matrix<double, kInputDim, Eigen::Dynamic, 0, kInputDim, kInputDim>;
/// State to reduced input (nz x nx).
using ReducedGain = Eigen::Matrix<double, Eigen::Dynamic, kStateDim, 0, kInputDim, kStateDim>;
/// Reduced input to state (nx x nz).
using StateReducedMatrix =
    Eigen::Matrix<double, kStateDim, Eigen::Dynamic, 0, kStateDim, kInputDim>;

/// The equality constraints solved for the input step: du = u0 + K dx + P dz.
struct InputProjection {
  Input u0 = Input::Zero();
  InputStateMatrix K = InputStateMatrix::Zero();
  ProjectionMatrix P;
};

/// Solves g + C dx + D du = 0 for du (see the file comment). D must have full row rank.
void calcInputProjection(const EqualityLinearization& eq, InputProjection& out);

/// One stage of the LQ problem in the reduced input dz:
///   dx+ = A dx + B dz + b,
///   cost 1/2 dx' Q dx + 1/2 dz' R dz + dz' S dx + q' dx + r' dz.
struct LqStage {
  StateMatrix A = StateMatrix::Zero();
  StateReducedMatrix B;
  State b = State::Zero();
  StateMatrix Q = StateMatrix::Zero();
  ReducedMatrix R;
  ReducedGain S;
  State q = State::Zero();
  ReducedVector r;
};

/// The LQ stage in dz of dynamics (A, B, b) and cost (quadratic model `cost`, already scaled
/// by the interval) in du, after substituting du = u0 + K dx + P dz.
void projectLqStage(const StateMatrix& A, const StateInputMatrix& B, const State& b,
                    const CostQuadratic& cost, const InputProjection& projection, LqStage& out);

/// Feedback law of one stage: dz = K dx + k.
struct RiccatiGain {
  ReducedGain K;
  ReducedVector k;
};

/// Backward Riccati recursion over `stages` with terminal cost 1/2 dx' QN dx + qN' dx.
/// The stage Hessians R + B' S B are regularised by adding `regularization` I (and more, up to
/// 1e6 times, when a Cholesky factorisation fails). Fills `gains` (resized by the caller to
/// stages.size()). Returns false if a Hessian could not be made positive definite.
bool solveRiccati(const std::vector<LqStage>& stages, const StateMatrix& QN, const State& qN,
                  double regularization, std::vector<RiccatiGain>& gains);

/// Forward pass: dx_0 given, dz_k = K_k dx_k + k_k, dx_{k+1} = A dx + B dz + b. `dx` has
/// stages.size() + 1 entries, `dz` stages.size().
void rolloutRiccati(const std::vector<LqStage>& stages, const std::vector<RiccatiGain>& gains,
                    const State& dx0, std::vector<State>& dx, std::vector<ReducedVector>& dz);

}  // namespace wj::nmpc
