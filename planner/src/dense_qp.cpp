// The dense interior-point QP of the SQP (see dense_qp.h).
#include "dense_qp.h"

#include <algorithm>
#include <cmath>

namespace wj::planner::detail {

namespace {

// Relative accuracy of a QP solution: the SQP's own tolerances are 1e-6.
constexpr double kQpTolerance = 1e-9;

}  // namespace

bool DenseQp::solve(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, const Eigen::MatrixXd& A,
                    const Eigen::VectorXd& b, const Eigen::VectorXd& rho, int max_iterations,
                    bool screen) {
  const int n = static_cast<int>(A.cols());
  const int all = static_cast<int>(A.rows()), dense_all = all - 2 * n;
  kept_.clear();
  for (int i = 0; i < dense_all; ++i) {
    if (screen) {
      // The row's least value over the box b[+e_j] <= d_j <= -b[-e_j].
      double least = 0.0;
      for (int j = 0; j < n; ++j) {
        const double a = A(i, j);
        least += a > 0.0 ? a * b[dense_all + 2 * j] : -a * b[dense_all + 2 * j + 1];
      }
      if (least > b[i] + 1e-12 * (1.0 + std::abs(b[i]))) continue;
    }
    kept_.push_back(i);
  }
  const int kept = static_cast<int>(kept_.size());
  rows_offered += dense_all;
  rows_kept += kept;
  resize(n, kept + 2 * n);
  for (int r = 0; r < kept; ++r) {
    Ad_.row(r) = A.row(kept_[r]);
    b_[r] = b[kept_[r]];
    rho_[r] = rho[kept_[r]];
  }
  b_.tail(2 * n) = b.tail(2 * n);
  rho_.tail(2 * n) = rho.tail(2 * n);
  const bool ok = solveKept(B, g, max_iterations);
  z_all_.setZero(all);
  for (int r = 0; r < kept; ++r) z_all_[kept_[r]] = z_[r];
  z_all_.tail(2 * n) = z_.tail(2 * n);
  return ok;
}

void DenseQp::resize(int n, int rows) {
  n_ = n;
  rows_ = rows;
  dense_ = rows - 2 * n;
  for (Eigen::VectorXd* v :
       {&w_,  &z_,  &s_,  &y_,   &rp_,  &rs_,  &D_,   &h_,        &rcw_, &rcs_, &dw_,
        &dz_, &ds_, &dy_, &dwa_, &dza_, &dsa_, &dya_, &tmp_rows_, &b_,   &rho_})
    v->resize(rows);
  for (Eigen::VectorXd* v : {&d_, &rd_, &dd_, &rhs_}) v->resize(n);
  M_.resize(n, n);
  Ad_.resize(dense_, n);
  AD_.resize(dense_, n);
  if (llt_size_ != n) {
    llt_ = Eigen::LLT<Eigen::MatrixXd>(n);
    llt_size_ = n;
  }
}

// The interior point on the kept rows: Ad_, then the 2n unit rows (b_, rho_ over both).
bool DenseQp::solveKept(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, int max_iterations) {
  ++solves;
  const Eigen::MatrixXd& Ad = Ad_;
  const Eigen::VectorXd& b = b_;
  const Eigen::VectorXd& rho = rho_;
  d_.setZero();
  for (int i = 0; i < rows_; ++i) {
    const double r0 = -b[i];  // a_i'd - b_i at d = 0
    if (rho[i] > 0) {
      s_[i] = std::max(1.0, 1.0 - r0);
      w_[i] = r0 + s_[i];
      z_[i] = std::min(1.0, 0.5 * rho[i]);
      y_[i] = rho[i] - z_[i];
    } else {
      s_[i] = 0.0;
      y_[i] = 0.0;
      w_[i] = std::max(1.0, r0);
      z_[i] = 1.0;
    }
  }
  int count = rows_;
  for (int i = 0; i < rows_; ++i) count += rho[i] > 0 ? 1 : 0;
  // Residuals relative to the data they are made of: the primal rows to b, stationarity and
  // the elastic rows to g and the penalties (the multipliers of elastic rows live in
  // [0, rho]), complementarity to both.
  const double primal_scale = 1.0 + b.lpNorm<Eigen::Infinity>();
  const double dual_scale =
      1.0 + std::max(g.lpNorm<Eigen::Infinity>(), rho.lpNorm<Eigen::Infinity>());
  for (int it = 0; it < max_iterations; ++it) {
    ++iterations;
    rd_.noalias() = B * d_;
    rd_ += g;
    transposeTimesSub(Ad, z_, rd_);
    times(Ad, d_, rp_);
    double mu = 0.0;
    for (int i = 0; i < rows_; ++i) {
      const bool el = rho[i] > 0;
      rp_[i] += (el ? s_[i] : 0.0) - b[i] - w_[i];
      rs_[i] = el ? rho[i] - z_[i] - y_[i] : 0.0;
      mu += w_[i] * z_[i] + (el ? s_[i] * y_[i] : 0.0);
    }
    mu /= std::max(1, count);
    if (rd_.lpNorm<Eigen::Infinity>() <= kQpTolerance * dual_scale &&
        rp_.lpNorm<Eigen::Infinity>() <= kQpTolerance * primal_scale &&
        rs_.lpNorm<Eigen::Infinity>() <= kQpTolerance * dual_scale &&
        mu <= 0.1 * kQpTolerance * primal_scale * dual_scale)
      break;
    // The Newton matrix (shared by the predictor and the corrector): B + A' D^-1 A, of which
    // the dense rows give a symmetric product (lower triangle, the one LLT reads) and the
    // unit rows the diagonal.
    for (int i = 0; i < rows_; ++i) {
      D_[i] = w_[i] / z_[i] + (rho[i] > 0 ? s_[i] / y_[i] : 0.0);
      tmp_rows_[i] = 1.0 / D_[i];
    }
    AD_.noalias() = tmp_rows_.head(dense_).asDiagonal() * Ad;
    for (int j = 0; j < n_; ++j) {
      for (int i = j; i < n_; ++i) M_(i, j) = B(i, j) + AD_.col(i).dot(Ad.col(j));
      M_(j, j) += tmp_rows_[dense_ + 2 * j] + tmp_rows_[dense_ + 2 * j + 1];
    }
    llt_.compute(M_);
    if (llt_.info() != Eigen::Success) {
      M_.diagonal().array() += 1e-10 * (1.0 + M_.diagonal().cwiseAbs().maxCoeff());
      llt_.compute(M_);
      if (llt_.info() != Eigen::Success) return false;
    }
    // Predictor (affine scaling).
    for (int i = 0; i < rows_; ++i) {
      rcw_[i] = -w_[i] * z_[i];
      rcs_[i] = -s_[i] * y_[i];
    }
    direction(Ad, rho);
    double alpha = stepToBoundary(rho, 1.0);
    double mu_aff = 0.0;
    for (int i = 0; i < rows_; ++i) {
      mu_aff += (w_[i] + alpha * dw_[i]) * (z_[i] + alpha * dz_[i]);
      if (rho[i] > 0) mu_aff += (s_[i] + alpha * ds_[i]) * (y_[i] + alpha * dy_[i]);
    }
    mu_aff /= std::max(1, count);
    const double sigma = std::pow(std::clamp(mu_aff / std::max(mu, 1e-300), 0.0, 1.0), 3);
    dwa_ = dw_;
    dza_ = dz_;
    dsa_ = ds_;
    dya_ = dy_;
    // Corrector.
    for (int i = 0; i < rows_; ++i) {
      rcw_[i] = sigma * mu - w_[i] * z_[i] - dwa_[i] * dza_[i];
      rcs_[i] = rho[i] > 0 ? sigma * mu - s_[i] * y_[i] - dsa_[i] * dya_[i] : 0.0;
    }
    direction(Ad, rho);
    alpha = stepToBoundary(rho, 0.995);
    d_ += alpha * dd_;
    w_ += alpha * dw_;
    z_ += alpha * dz_;
    s_ += alpha * ds_;
    y_ += alpha * dy_;
  }
  return true;
}

// out = A d over all rows (dense rows Ad, then the unit rows).
void DenseQp::times(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& d,
                    Eigen::VectorXd& out) const {
  out.head(dense_).noalias() = Ad * d;
  for (int j = 0; j < n_; ++j) {
    out[dense_ + 2 * j] = d[j];
    out[dense_ + 2 * j + 1] = -d[j];
  }
}
// out -= A' v over all rows.
void DenseQp::transposeTimesSub(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& v,
                                Eigen::VectorXd& out) const {
  out.noalias() -= Ad.transpose() * v.head(dense_);
  for (int j = 0; j < n_; ++j) out[j] -= v[dense_ + 2 * j] - v[dense_ + 2 * j + 1];
}

// The Newton direction for the complementarity right-hand sides rcw_, rcs_ (residuals in
// rd_, rp_, rs_; factorisation in llt_).
void DenseQp::direction(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& rho) {
  for (int i = 0; i < rows_; ++i) {
    h_[i] = -rp_[i] + rcw_[i] / z_[i];
    if (rho[i] > 0) h_[i] -= (rcs_[i] - s_[i] * rs_[i]) / y_[i];
    tmp_rows_[i] = h_[i] / D_[i];
  }
  rhs_ = rd_;
  transposeTimesSub(Ad, tmp_rows_, rhs_);
  rhs_ = -rhs_;
  dd_ = llt_.solve(rhs_);
  times(Ad, dd_, tmp_rows_);
  for (int i = 0; i < rows_; ++i) {
    dz_[i] = (h_[i] - tmp_rows_[i]) / D_[i];
    dw_[i] = (rcw_[i] - w_[i] * dz_[i]) / z_[i];
    if (rho[i] > 0) {
      dy_[i] = rs_[i] - dz_[i];
      ds_[i] = (rcs_[i] - s_[i] * dy_[i]) / y_[i];
    } else {
      dy_[i] = ds_[i] = 0.0;
    }
  }
}

// Largest alpha <= 1 keeping (w, z, s, y) >= (1 - fraction) of their values.
double DenseQp::stepToBoundary(const Eigen::VectorXd& rho, double fraction) const {
  double alpha = 1.0;
  auto limit = [&](double v, double dv) {
    if (dv < 0) alpha = std::min(alpha, -fraction * v / dv);
  };
  for (int i = 0; i < rows_; ++i) {
    limit(w_[i], dw_[i]);
    limit(z_[i], dz_[i]);
    if (rho[i] > 0) {
      limit(s_[i], ds_[i]);
      limit(y_[i], dy_[i]);
    }
  }
  return alpha;
}

}  // namespace wj::planner::detail
