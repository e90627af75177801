#pragma once
/// @file The QP of one SQP iteration (dense_sqp.h), in inequality form:
///   min 1/2 d'Bd + g'd + sum_i rho_i s_i   s.t.  a_i'd + s_i >= b_i,  s_i >= 0,
/// where s_i is present (an elastic row) only where rho_i > 0 (the linearised constraints; the
/// variable bounds are hard rows, met by d = 0). Primal-dual interior point with Mehrotra's
/// predictor-corrector (Nocedal & Wright 2006, Algorithm 16.4) on
///   B d + g - A'z = 0,  rho - z - y = 0 (elastic rows),  A d + s - b - w = 0,
///   w.z = mu,  s.y = mu,
/// with slacks w, s and multipliers z, y all > 0. The slacks and multipliers are eliminated
/// row by row, which leaves one n x n system (B + A' D^-1 A) dd = r per solve (D diagonal).
/// Internal to the planner library.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <vector>

namespace wj::planner::detail {

/// The QP solver with its workspace: one per concurrent solve, reused across solves.
class DenseQp {
 public:
  /// Solves the QP for `A` with `rows` rows in all: the first rows - 2n are dense (the
  /// linearised constraints); then each variable j has two unit rows, +e_j (lower bound) at
  /// dense + 2j and -e_j (upper) after it. Those never enter a product: they add to the Newton
  /// matrix's diagonal only. They bound d to a box, and with `screen` the dense rows that hold
  /// everywhere in that box are left out: they can neither bind nor be violated, so the
  /// solution is the same, and an interior-point iteration costs O(kept rows n^2). False if
  /// the Newton matrix cannot be factorised. The result is usable when the iteration limit
  /// ends the solve first (the SQP's line search judges it). multipliers() are over all rows
  /// (0 on those left out).
  bool solve(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, const Eigen::MatrixXd& A,
             const Eigen::VectorXd& b, const Eigen::VectorXd& rho, int max_iterations, bool screen);

  int solves = 0, iterations = 0;        ///< counters for diagnosis
  long rows_offered = 0, rows_kept = 0;  ///< dense rows, summed over the solves
  /// The step d of the last solve.
  const Eigen::VectorXd& step() const { return d_; }
  /// The multipliers z of the last solve, over all rows.
  const Eigen::VectorXd& multipliers() const { return z_all_; }

 private:
  void resize(int n, int rows);
  bool solveKept(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, int max_iterations);
  void times(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& d, Eigen::VectorXd& out) const;
  void transposeTimesSub(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& v,
                         Eigen::VectorXd& out) const;
  void direction(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& rho);
  double stepToBoundary(const Eigen::VectorXd& rho, double fraction) const;

  int n_ = 0, rows_ = 0, dense_ = 0, llt_size_ = -1;
  Eigen::VectorXd d_, rd_, dd_, rhs_;
  Eigen::VectorXd w_, z_, s_, y_, rp_, rs_, D_, h_, rcw_, rcs_, dw_, dz_, ds_, dy_;
  Eigen::VectorXd dwa_, dza_, dsa_, dya_, tmp_rows_, b_, rho_, z_all_;
  Eigen::MatrixXd M_, Ad_, AD_;
  std::vector<int> kept_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

}  // namespace wj::planner::detail
