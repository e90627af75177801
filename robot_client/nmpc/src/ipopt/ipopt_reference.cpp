// Ipopt 3.11 from Debian: headers under coin/, MUMPS as the linear solver.
#include "nmpc/ipopt_reference.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>
#include <mutex>

#include "nmpc/discretization.h"

namespace wj::nmpc {

namespace {

// MUMPS' sequential build shares Fortran state between instances: one solve at a time.
std::mutex& ipoptMutex() {
  static std::mutex m;
  return m;
}

constexpr int kNodeVars = kStateDim + kInputDim;

// min sum_k dt l(x_k, u_k) + V(x_N)  s.t.  x_0 = x0 (fixed bounds),
// F(x_k, u_k) - x_{k+1} = 0, g_k(x_k, u_k) = 0. Variables interleaved [x_0, u_0, x_1, ..., x_N].
class CentroidalNlp final : public Ipopt::TNLP {
 public:
  CentroidalNlp(const SqpSettings& sqp, const CentroidalOcp& ocp, double t0, const State& x0,
                const Targets& targets, IpoptHessian hessian)
      : sqp_(sqp), ocp_(ocp), x0_(x0), hessian_(hessian) {
    n_ = static_cast<int>(std::ceil(sqp.horizon_s / sqp.dt_s - 1e-9));
    dt_ = sqp.horizon_s / n_;
    for (int k = 0; k <= n_; ++k) nodes_.push_back(ocp.calcNodeTargets(targets, t0 + k * dt_));
    for (int k = 0; k < n_; ++k) {
      row_.push_back(m_);
      m_ += kStateDim + CentroidalOcp::numEqualities(nodes_[k].contact);
    }
    data_.resize(n_ + 1);
    x_next_.resize(n_);
    A_.resize(n_);
    B_.resize(n_);
    cost_.resize(n_ + 1);
    eq_.resize(n_);
  }

  IpoptReferenceResult result;

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) override {
    n = numVars();
    m = m_;
    nnz_jac_g = 0;
    for (int k = 0; k < n_; ++k)
      nnz_jac_g +=
          kStateDim * (kNodeVars + 1) + CentroidalOcp::numEqualities(nodes_[k].contact) * kNodeVars;
    // Lower triangle of one dense (x_k, u_k) block per interval and the terminal state block.
    nnz_h_lag = hessian_ == IpoptHessian::LimitedMemory
                    ? 0
                    : n_ * kNodeVars * (kNodeVars + 1) / 2 + kStateDim * (kStateDim + 1) / 2;
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index m,
                       Ipopt::Number* g_l, Ipopt::Number* g_u) override {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = -2e19;
      x_u[i] = 2e19;
    }
    for (int i = 0; i < kStateDim; ++i) x_l[i] = x_u[i] = x0_[i];
    for (Ipopt::Index i = 0; i < m; ++i) g_l[i] = g_u[i] = 0.0;
    return true;
  }

  bool get_starting_point(Ipopt::Index, bool init_x, Ipopt::Number* w, bool, Ipopt::Number*,
                          Ipopt::Number*, Ipopt::Index, bool, Ipopt::Number*) override {
    if (!init_x) return true;
    for (int k = 0; k <= n_; ++k) {
      for (int i = 0; i < kStateDim; ++i) w[xi(k) + i] = x0_[i];
      if (k < n_)
        for (int i = 0; i < kInputDim; ++i) w[ui(k) + i] = nodes_[k].u_ref[i];
    }
    return true;
  }

  bool eval_f(Ipopt::Index n, const Ipopt::Number* w, bool new_x, Ipopt::Number& f) override {
    update(n, w, new_x);
    f = 0.0;
    for (int k = 0; k <= n_; ++k) f += cost_[k].value;
    return true;
  }

  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* w, bool new_x,
                   Ipopt::Number* grad) override {
    update(n, w, new_x);
    for (int k = 0; k <= n_; ++k) {
      for (int i = 0; i < kStateDim; ++i) grad[xi(k) + i] = cost_[k].dx[i];
      if (k < n_)
        for (int i = 0; i < kInputDim; ++i) grad[ui(k) + i] = cost_[k].du[i];
    }
    return true;
  }

  bool eval_g(Ipopt::Index n, const Ipopt::Number* w, bool new_x, Ipopt::Index,
              Ipopt::Number* g) override {
    update(n, w, new_x);
    for (int k = 0; k < n_; ++k) {
      const State defect = x_next_[k] - stateAt(w, k + 1);
      for (int i = 0; i < kStateDim; ++i) g[row_[k] + i] = defect[i];
      for (int i = 0; i < eq_[k].g.size(); ++i) g[row_[k] + kStateDim + i] = eq_[k].g[i];
    }
    return true;
  }

  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number* w, bool new_x, Ipopt::Index, Ipopt::Index,
                  Ipopt::Index* iRow, Ipopt::Index* jCol, Ipopt::Number* values) override {
    Ipopt::Index idx = 0;
    if (!values) {
      for (int k = 0; k < n_; ++k) {
        const int me = CentroidalOcp::numEqualities(nodes_[k].contact);
        for (int r = 0; r < kStateDim; ++r) {
          for (int c = 0; c < kNodeVars; ++c, ++idx) {
            iRow[idx] = row_[k] + r;
            jCol[idx] = xi(k) + c;
          }
          iRow[idx] = row_[k] + r;
          jCol[idx] = xi(k + 1) + r;
          ++idx;
        }
        for (int r = 0; r < me; ++r)
          for (int c = 0; c < kNodeVars; ++c, ++idx) {
            iRow[idx] = row_[k] + kStateDim + r;
            jCol[idx] = xi(k) + c;
          }
      }
      return true;
    }
    update(n, w, new_x);
    for (int k = 0; k < n_; ++k) {
      for (int r = 0; r < kStateDim; ++r) {
        for (int c = 0; c < kStateDim; ++c) values[idx++] = A_[k](r, c);
        for (int c = 0; c < kInputDim; ++c) values[idx++] = B_[k](r, c);
        values[idx++] = -1.0;
      }
      for (int r = 0; r < eq_[k].g.size(); ++r) {
        for (int c = 0; c < kStateDim; ++c) values[idx++] = eq_[k].C(r, c);
        for (int c = 0; c < kInputDim; ++c) values[idx++] = eq_[k].D(r, c);
      }
    }
    return true;
  }

  bool eval_h(Ipopt::Index n, const Ipopt::Number* w, bool new_x, Ipopt::Number obj_factor,
              Ipopt::Index, const Ipopt::Number* lambda, bool, Ipopt::Index, Ipopt::Index* iRow,
              Ipopt::Index* jCol, Ipopt::Number* values) override {
    Ipopt::Index idx = 0;
    if (!values) {
      for (int k = 0; k <= n_; ++k) {
        const int dim = k < n_ ? kNodeVars : kStateDim;
        for (int i = 0; i < dim; ++i)
          for (int j = 0; j <= i; ++j, ++idx) {
            iRow[idx] = xi(k) + i;
            jCol[idx] = xi(k) + j;
          }
      }
      return true;
    }
    update(n, w, new_x);
    Eigen::Matrix<double, kNodeVars, kNodeVars> H;
    for (int k = 0; k <= n_; ++k) {
      const int dim = k < n_ ? kNodeVars : kStateDim;
      H.setZero();
      H.topLeftCorner<kStateDim, kStateDim>() = obj_factor * cost_[k].dxx;
      if (k < n_) {
        H.bottomRightCorner<kInputDim, kInputDim>() = obj_factor * dt_ * cost_[k].duu;
        H.topLeftCorner<kStateDim, kStateDim>() *= dt_;
        if (hessian_ == IpoptHessian::FiniteDifference)
          H += calcConstraintCurvature(k, stateAt(w, k), inputAt(w, k), lambda + row_[k]);
      }
      for (int i = 0; i < dim; ++i)
        for (int j = 0; j <= i; ++j) values[idx++] = 0.5 * (H(i, j) + H(j, i));
    }
    return true;
  }

  bool intermediate_callback(Ipopt::AlgorithmMode, Ipopt::Index iter, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    result.iterations = iter;
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index n, const Ipopt::Number* w,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number obj,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    update(n, w, true);
    result.cost = obj;
    result.x.resize(n_ + 1);
    result.u.resize(n_);
    double violation_sq = 0.0;
    for (int k = 0; k <= n_; ++k) {
      result.x[k] = stateAt(w, k);
      if (k < n_) {
        result.u[k] = inputAt(w, k);
        violation_sq += (x_next_[k] - stateAt(w, k + 1)).squaredNorm() + eq_[k].g.squaredNorm();
      }
    }
    result.violation = std::sqrt(violation_sq);
  }

 private:
  int numVars() const { return (n_ + 1) * kStateDim + n_ * kInputDim; }
  static int xi(int k) { return k * kNodeVars; }
  static int ui(int k) { return k * kNodeVars + kStateDim; }
  static State stateAt(const Ipopt::Number* w, int k) { return Eigen::Map<const State>(w + xi(k)); }
  static Input inputAt(const Ipopt::Number* w, int k) { return Eigen::Map<const Input>(w + ui(k)); }

  // d/dz of (lambda_dyn' F(z) + lambda_eq' g(z)) at z = (x, u), i.e. A' ld + C' le stacked
  // with B' ld + D' le, from the analytic Jacobians.
  Eigen::Matrix<double, kNodeVars, 1> constraintGradient(int k, const State& x, const Input& u,
                                                         const Ipopt::Number* lambda) {
    const CentroidalModel& model = ocp_.model();
    ModelData data;
    model.updateData(x, data);
    State x_next;
    StateMatrix A;
    StateInputMatrix B;
    calcDiscreteDynamicsJacobians(model, sqp_.integrator, x, u, nodes_[k].normal, dt_, data,
                                  scratch_, x_next, A, B);
    EqualityLinearization eq;
    ocp_.calcEqualitiesLinear(nodes_[k], x, u, data, eq);
    const Eigen::Map<const State> ld(lambda);
    const Eigen::Map<const Eigen::VectorXd> le(lambda + kStateDim, eq.g.size());
    Eigen::Matrix<double, kNodeVars, 1> grad;
    grad.head<kStateDim>() = A.transpose() * ld + eq.C.transpose() * le;
    grad.tail<kInputDim>() = B.transpose() * ld + eq.D.transpose() * le;
    return grad;
  }

  // Multiplier-weighted curvature of interval k's constraints by central differences.
  Eigen::Matrix<double, kNodeVars, kNodeVars> calcConstraintCurvature(int k, const State& x,
                                                                      const Input& u,
                                                                      const Ipopt::Number* lambda) {
    Eigen::Matrix<double, kNodeVars, kNodeVars> H;
    for (int i = 0; i < kNodeVars; ++i) {
      State xp = x, xm = x;
      Input up = u, um = u;
      const double h = 1e-6 * std::max(1.0, std::abs(i < kStateDim ? x[i] : u[i - kStateDim]));
      if (i < kStateDim) {
        xp[i] += h;
        xm[i] -= h;
      } else {
        up[i - kStateDim] += h;
        um[i - kStateDim] -= h;
      }
      H.col(i) = (constraintGradient(k, xp, up, lambda) - constraintGradient(k, xm, um, lambda)) /
                 (2.0 * h);
    }
    return H;
  }

  // Everything at w, once per new point: the same derivatives the SQP linearises with.
  void update(Ipopt::Index, const Ipopt::Number* w, bool new_x) {
    if (!new_x && have_) return;
    have_ = true;
    const CentroidalModel& model = ocp_.model();
    for (int k = 0; k < n_; ++k) {
      const State x = stateAt(w, k);
      const Input u = inputAt(w, k);
      model.updateData(x, data_[k]);
      calcDiscreteDynamicsJacobians(model, sqp_.integrator, x, u, nodes_[k].normal, dt_, data_[k],
                                    scratch_, x_next_[k], A_[k], B_[k]);
      CostQuadratic& c = cost_[k];
      ocp_.calcStageCostQuadratic(nodes_[k], x, u, c);
      c.value *= dt_;
      c.dx *= dt_;
      c.du *= dt_;
      ocp_.calcEqualitiesLinear(nodes_[k], x, u, data_[k], eq_[k]);
    }
    ocp_.calcTerminalCostQuadratic(nodes_[n_], stateAt(w, n_), cost_[n_]);
  }

  const SqpSettings& sqp_;
  const CentroidalOcp& ocp_;
  State x0_;
  IpoptHessian hessian_;
  int n_ = 0;
  int m_ = 0;
  double dt_ = 0.0;
  bool have_ = false;
  std::vector<NodeTargets> nodes_;
  std::vector<int> row_;
  std::vector<ModelData> data_;
  ModelData scratch_;
  std::vector<State> x_next_;
  std::vector<StateMatrix> A_;
  std::vector<StateInputMatrix> B_;
  std::vector<CostQuadratic> cost_;
  std::vector<EqualityLinearization> eq_;
};

}  // namespace

IpoptReferenceResult solveWithIpopt(const SqpSettings& sqp_settings, const CentroidalOcp& problem,
                                    double t0, const State& x0, const Targets& targets,
                                    const IpoptReferenceSettings& settings) {
  sqp_settings.validate();
  Ipopt::SmartPtr<CentroidalNlp> nlp =
      new CentroidalNlp(sqp_settings, problem, t0, x0, targets, settings.hessian);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetIntegerValue("print_level", settings.print_level);
  if (settings.hessian == IpoptHessian::LimitedMemory) {
    app->Options()->SetStringValue("hessian_approximation", "limited-memory");
    app->Options()->SetIntegerValue("limited_memory_max_history", settings.lbfgs_memory);
  }
  app->Options()->SetIntegerValue("max_iter", settings.max_iterations);
  app->Options()->SetNumericValue("tol", settings.tolerance);
  app->Options()->SetNumericValue("constr_viol_tol", 1e-10);
  app->Options()->SetNumericValue("acceptable_tol", 1e-30);  // no early "acceptable" exit
  app->Options()->SetStringValue("mu_strategy", "adaptive");
  std::lock_guard<std::mutex> lock(ipoptMutex());
  IpoptReferenceResult out;
  if (app->Initialize() != Ipopt::Solve_Succeeded) {
    out.status = "initialize_failed";
    return out;
  }
  const auto start = std::chrono::steady_clock::now();
  const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(nlp);
  out = nlp->result;
  out.solve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  out.solved = status == Ipopt::Solve_Succeeded;
  switch (status) {
    case Ipopt::Solve_Succeeded:
      out.status = "Solve_Succeeded";
      break;
    case Ipopt::Solved_To_Acceptable_Level:
      out.status = "Solved_To_Acceptable_Level";
      break;
    case Ipopt::Maximum_Iterations_Exceeded:
      out.status = "Maximum_Iterations_Exceeded";
      break;
    case Ipopt::Restoration_Failed:
      out.status = "Restoration_Failed";
      break;
    case Ipopt::Search_Direction_Becomes_Too_Small:
      out.status = "Search_Direction_Becomes_Too_Small";
      break;
    default:
      out.status = "status_" + std::to_string(static_cast<int>(status));
  }
  return out;
}

}  // namespace wj::nmpc
