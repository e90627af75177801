// Constraint projection and Riccati recursion against a dense KKT solve of the same
// equality-constrained LQ problem.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <random>
#include <vector>

#include "nmpc/riccati.h"

namespace wj::nmpc {
namespace {

Eigen::MatrixXd randomMatrix(int rows, int cols, std::mt19937& rng, double scale = 1.0) {
  std::normal_distribution<double> n(0.0, scale);
  Eigen::MatrixXd M(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) M(i, j) = n(rng);
  return M;
}

EqualityLinearization randomEqualities(int m, std::mt19937& rng) {
  EqualityLinearization eq;
  eq.g = randomMatrix(m, 1, rng);
  eq.C = randomMatrix(m, kStateDim, rng);
  eq.D = randomMatrix(m, kInputDim, rng);
  return eq;
}

TEST(Projection, SatisfiesTheConstraintsForEveryReducedInput) {
  std::mt19937 rng(3);
  for (const int m : {0, 4, 10, 16}) {
    const EqualityLinearization eq = randomEqualities(m, rng);
    InputProjection p;
    calcInputProjection(eq, p);
    ASSERT_EQ(p.P.cols(), kInputDim - m);
    EXPECT_LT(
        (p.P.transpose() * p.P - Eigen::MatrixXd::Identity(kInputDim - m, kInputDim - m)).norm(),
        1e-12);
    if (m > 0) {
      EXPECT_LT((eq.D * p.P).norm(), 1e-12);
    }
    for (int trial = 0; trial < 3; ++trial) {
      const State dx = randomMatrix(kStateDim, 1, rng);
      const Eigen::VectorXd dz = randomMatrix(kInputDim - m, 1, rng);
      const Input du = p.u0 + p.K * dx + p.P * dz;
      if (m > 0) {
        EXPECT_LT((eq.g + eq.C * dx + eq.D * du).norm(), 1e-11);
      }
    }
    // u0 is the minimum-norm particular solution: orthogonal to the null space.
    EXPECT_LT((p.P.transpose() * p.u0).norm(), 1e-12);
  }
}

// min sum_k 1/2 dx'Q dx + 1/2 du'R du + q'dx + r'du + terminal
// s.t. dx_{k+1} = A dx + B du + b, g + C dx + D du = 0, dx_0 = 0,
// solved (a) by projection + Riccati, (b) by one dense KKT system.
TEST(Riccati, MatchesADenseKktSolveOfTheConstrainedLqProblem) {
  std::mt19937 rng(11);
  const int N = 5;
  const int nx = kStateDim, nu = kInputDim;
  const std::vector<int> m_of = {6, 16, 0, 10, 8};
  std::vector<StateMatrix> A(N);
  std::vector<StateInputMatrix> B(N);
  std::vector<State> b(N);
  std::vector<CostQuadratic> cost(N + 1);
  std::vector<EqualityLinearization> eq(N);
  for (int k = 0; k < N; ++k) {
    A[k] = StateMatrix::Identity() + randomMatrix(nx, nx, rng, 0.1);
    B[k] = randomMatrix(nx, nu, rng, 0.1);
    b[k] = randomMatrix(nx, 1, rng, 0.1);
    const Eigen::MatrixXd Mq = randomMatrix(nx, nx, rng), Mr = randomMatrix(nu, nu, rng);
    cost[k].dxx = Mq * Mq.transpose() / nx + StateMatrix::Identity();
    cost[k].duu = Mr * Mr.transpose() / nu + InputMatrix::Identity();
    cost[k].dx = randomMatrix(nx, 1, rng);
    cost[k].du = randomMatrix(nu, 1, rng);
    eq[k] = randomEqualities(m_of[k], rng);
  }
  const Eigen::MatrixXd Mq = randomMatrix(nx, nx, rng);
  cost[N].dxx = Mq * Mq.transpose() / nx + StateMatrix::Identity();
  cost[N].dx = randomMatrix(nx, 1, rng);

  // Every other stage with a 3 x 3 block-diagonal input Hessian (the projection's fast path).
  for (int k = 1; k < N; k += 2) {
    InputMatrix R = InputMatrix::Zero();
    for (int i = 0; i < nu; i += 3) R.block<3, 3>(i, i) = cost[k].duu.block<3, 3>(i, i);
    cost[k].duu = R;
    cost[k].duu_block_diagonal = true;
  }

  // (a) projection + Riccati.
  std::vector<InputProjection> proj(N);
  std::vector<LqStage> lq(N);
  for (int k = 0; k < N; ++k) {
    calcInputProjection(eq[k], proj[k]);
    projectLqStage(A[k], B[k], b[k], cost[k], proj[k], lq[k]);
  }
  std::vector<RiccatiGain> gains(N);
  ASSERT_TRUE(solveRiccati(lq, cost[N].dxx, cost[N].dx, 0.0, gains));
  std::vector<State> dx(N + 1);
  std::vector<ReducedVector> dz(N);
  rolloutRiccati(lq, gains, State::Zero(), dx, dz);
  std::vector<Input> du(N);
  for (int k = 0; k < N; ++k) du[k] = proj[k].u0 + proj[k].K * dx[k] + proj[k].P * dz[k];

  // (b) dense KKT. Variables: w = [dx_1..dx_N, du_0..du_{N-1}].
  const int nw = N * nx + N * nu;
  int nc = N * nx;
  for (int m : m_of) nc += m;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(nw, nw), G = Eigen::MatrixXd::Zero(nc, nw);
  Eigen::VectorXd h = Eigen::VectorXd::Zero(nw), c = Eigen::VectorXd::Zero(nc);
  const auto xi = [&](int k) { return (k - 1) * nx; };  // dx_k, k >= 1
  const auto ui = [&](int k) { return N * nx + k * nu; };
  int row = 0;
  for (int k = 0; k < N; ++k) {
    if (k > 0) {
      H.block(xi(k), xi(k), nx, nx) = cost[k].dxx;
      h.segment(xi(k), nx) = cost[k].dx;
    }
    H.block(ui(k), ui(k), nu, nu) = cost[k].duu;
    h.segment(ui(k), nu) = cost[k].du;
    // dx_{k+1} - A dx_k - B du_k = b
    G.block(row, xi(k + 1), nx, nx) = Eigen::MatrixXd::Identity(nx, nx);
    if (k > 0) G.block(row, xi(k), nx, nx) = -A[k];
    G.block(row, ui(k), nx, nu) = -B[k];
    c.segment(row, nx) = b[k];
    row += nx;
    const int m = m_of[k];
    if (m > 0) {
      if (k > 0) G.block(row, xi(k), m, nx) = eq[k].C;
      G.block(row, ui(k), m, nu) = eq[k].D;
      c.segment(row, m) = -eq[k].g;
      row += m;
    }
  }
  H.block(xi(N), xi(N), nx, nx) = cost[N].dxx;
  h.segment(xi(N), nx) = cost[N].dx;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(nw + nc, nw + nc);
  K.topLeftCorner(nw, nw) = H;
  K.topRightCorner(nw, nc) = G.transpose();
  K.bottomLeftCorner(nc, nw) = G;
  Eigen::VectorXd rhs(nw + nc);
  rhs << -h, c;
  const Eigen::VectorXd sol = K.fullPivLu().solve(rhs);
  double worst = 0.0;
  for (int k = 1; k <= N; ++k)
    worst = std::max(worst, (dx[k] - sol.segment(xi(k), nx)).cwiseAbs().maxCoeff());
  for (int k = 0; k < N; ++k)
    worst = std::max(worst, (du[k] - sol.segment(ui(k), nu)).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-8 * std::max(1.0, sol.cwiseAbs().maxCoeff()));
}

}  // namespace
}  // namespace wj::nmpc
