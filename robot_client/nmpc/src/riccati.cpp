#include "nmpc/riccati.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>

namespace wj::nmpc {

void calcInputProjection(const EqualityLinearization& eq, InputProjection& out) {
  const int m = static_cast<int>(eq.g.size());
  if (m == 0) {
    out.u0.setZero();
    out.K.setZero();
    out.P.setIdentity(kInputDim, kInputDim);
    return;
  }
  using DT = Eigen::Matrix<double, kInputDim, Eigen::Dynamic, 0, kInputDim, kMaxEqualities>;
  const DT Dt = eq.D.transpose();
  const Eigen::HouseholderQR<DT> qr(Dt);
  InputMatrix Q;
  Q.setIdentity();
  Q.applyOnTheLeft(qr.householderQ());
  const auto R1t = qr.matrixQR().topRows(m).template triangularView<Eigen::Upper>().transpose();
  const EqVector y = R1t.solve(eq.g);
  const EqStateMatrix Y = R1t.solve(eq.C);
  out.u0.noalias() = -Q.leftCols(m) * y;
  out.K.noalias() = -Q.leftCols(m) * Y;
  out.P = Q.rightCols(kInputDim - m);
}

void projectLqStage(const StateMatrix& A, const StateInputMatrix& B, const State& b,
                    const CostQuadratic& cost, const InputProjection& pr, LqStage& out) {
  out.A = A;
  out.A.noalias() += B * pr.K;
  out.B.noalias() = B * pr.P;
  out.b = b;
  out.b.noalias() += B * pr.u0;
  InputStateMatrix RK;
  ProjectionMatrix RP(kInputDim, pr.P.cols());
  if (cost.duu_block_diagonal) {
    for (int i = 0; i < kInputDim; i += 3) {
      const Eigen::Matrix3d Rb = cost.duu.block<3, 3>(i, i);
      RK.middleRows<3>(i).noalias() = Rb * pr.K.middleRows<3>(i);
      RP.middleRows<3>(i).noalias() = Rb * pr.P.middleRows<3>(i);
    }
  } else {
    RK.noalias() = cost.duu * pr.K;
    RP.noalias() = cost.duu * pr.P;
  }
  Input r = cost.du;
  r.noalias() += cost.duu * pr.u0;
  out.Q = cost.dxx;
  out.Q.noalias() += pr.K.transpose() * RK;
  out.q = cost.dx;
  out.q.noalias() += pr.K.transpose() * r;
  out.R.noalias() = pr.P.transpose() * RP;
  out.S.noalias() = pr.P.transpose() * RK;
  out.r.noalias() = pr.P.transpose() * r;
}

bool solveRiccati(const std::vector<LqStage>& stages, const StateMatrix& QN, const State& qN,
                  double regularization, std::vector<RiccatiGain>& gains) {
  StateMatrix S = QN;  // value function Hessian of the next stage
  State s = qN;        // and gradient
  StateMatrix SA;
  StateReducedMatrix SB;
  ReducedMatrix H;
  ReducedGain G;
  ReducedVector h;
  Eigen::LLT<ReducedMatrix> llt;
  for (int k = static_cast<int>(stages.size()) - 1; k >= 0; --k) {
    const LqStage& st = stages[k];
    SA.noalias() = S * st.A;
    SB.noalias() = S * st.B;
    State Sb_s = s;
    Sb_s.noalias() += S * st.b;
    H = st.R;
    H.noalias() += st.B.transpose() * SB;
    G = st.S;
    G.noalias() += st.B.transpose() * SA;
    h = st.r;
    h.noalias() += st.B.transpose() * Sb_s;
    double reg = regularization;
    for (;;) {
      ReducedMatrix Hr = H;
      Hr.diagonal().array() += reg;
      llt.compute(Hr);
      if (llt.info() == Eigen::Success) break;
      reg = reg > 0.0 ? 10.0 * reg : 1e-9;
      if (reg > 1e6 * std::max(regularization, 1e-3)) return false;
    }
    RiccatiGain& gain = gains[k];
    gain.K = -llt.solve(G);
    gain.k = -llt.solve(h);
    StateMatrix Snew = st.Q;
    Snew.noalias() += st.A.transpose() * SA;
    Snew.noalias() += G.transpose() * gain.K;
    S = 0.5 * (Snew + Snew.transpose());
    State snew = st.q;
    snew.noalias() += st.A.transpose() * Sb_s;
    snew.noalias() += G.transpose() * gain.k;
    s = snew;
  }
  return true;
}

void rolloutRiccati(const std::vector<LqStage>& stages, const std::vector<RiccatiGain>& gains,
                    const State& dx0, std::vector<State>& dx, std::vector<ReducedVector>& dz) {
  dx[0] = dx0;
  for (std::size_t k = 0; k < stages.size(); ++k) {
    dz[k] = gains[k].k;
    dz[k].noalias() += gains[k].K * dx[k];
    dx[k + 1] = stages[k].b;
    dx[k + 1].noalias() += stages[k].A * dx[k];
    dx[k + 1].noalias() += stages[k].B * dz[k];
  }
}

}  // namespace wj::nmpc
