#pragma once
/// @file The polish NLP of a DE candidate, shared by its solvers (Ipopt, dense SQP):
///   min energy_weight * energy(u)  s.t.  near-active sampled margins >= polish.backoff,
///   target errors = 0,  |landing pitch| <= tolerance (apex targets),  box bounds,
/// over the free variables of the search vector (those with upper > lower bound). With
/// PolishGoal::ClosestApproach the target errors leave the constraints and enter the objective
/// as the planner's target cost, sum of (error / tolerance)^2.
/// Internal to the planner library.

#include <Eigen/Core>
#include <chrono>
#include <limits>
#include <vector>

#include "de/batch_team.h"
#include "planner/jump_model.h"
#include "planner/jump_planner.h"

namespace wj::planner {

/// Constraint violation (scaled margins, target residuals) at which a point counts as meeting
/// the constraints; the full evaluation re-checks every sample before the point is accepted.
inline constexpr double kPolishConstraintTolerance = 1e-6;

/// How long the polish's idle team threads spin before they sleep: the serial work between two
/// Jacobians (QPs, line search) takes longer, so they sleep, and a wake-up costs ~45 us on this
/// VM (batch_team.h) against ~400 us of columns shared.
inline constexpr std::chrono::microseconds kPolishTeamSpin{50};

/// The polish problem of one candidate; x is the vector of free variables. Not thread-safe
/// (value() writes a workspace); one per polish.
class PolishProblem {
 public:
  PolishProblem(const JumpModel& model, const Eigen::VectorXd& u0,
                PolishGoal goal = PolishGoal::MeetTarget);

  int numVariables() const { return static_cast<int>(free_.size()); }
  int numConstraints() const { return m_; }
  /// Bounds of x and of c(x) (2e19 = no upper bound).
  const Eigen::VectorXd& xLower() const { return xl_; }
  const Eigen::VectorXd& xUpper() const { return xu_; }
  const Eigen::VectorXd& cLower() const { return cl_; }
  const Eigen::VectorXd& cUpper() const { return cu_; }
  /// The free variables of u0.
  Eigen::VectorXd startPoint() const;
  /// The full search vector for x (the fixed variables as in u0).
  Eigen::VectorXd fullVector(const Eigen::VectorXd& x) const;

  /// Objective and constraints at x; false if the model has no trajectory there.
  bool value(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c);
  /// Forward-difference gradient and Jacobian (m x n) at x, given f and c there; each probe
  /// steps inward at the upper bound so that it stays in the box. Within solveWithThreads(), the
  /// columns are shared among its threads; the result is the same.
  bool derivatives(const Eigen::VectorXd& x, double f, const Eigen::VectorXd& c,
                   Eigen::VectorXd& grad, Eigen::MatrixXd& jac);
  /// Runs solve() (a solver working on this problem) with `threads` threads, the calling one
  /// included, sharing the Jacobian's columns, and returns its result.
  template <class Solve>
  auto solveWithThreads(int threads, Solve&& solve) -> decltype(solve()) {
    return de::runWithTeam(threads, kPolishTeamSpin, [&](de::BatchTeam* team) {
      // The team ends with this call, however solve() leaves it.
      struct Forget {
        PolishProblem& p;
        ~Forget() { p.setTeam(nullptr, 1); }
      } forget{*this};
      setTeam(team, threads);
      return solve();
    });
  }
  /// Max violation of c's bounds.
  double violation(const Eigen::VectorXd& c) const;

  /// Keeps (x, f) if c meets the constraints to kPolishConstraintTolerance and f is the lowest
  /// so far.
  void rememberIfBest(const Eigen::VectorXd& x, double f, const Eigen::VectorXd& c);
  bool hasFeasible() const { return best_x_.size() > 0; }
  double bestObjective() const { return best_f_; }
  const Eigen::VectorXd& bestFeasible() const { return best_x_; }

 private:
  // The sampled constraints passed to the solver: those within kActiveMargin (scaled) of their
  // bound that are a local minimum of their channel over time, and the samples on either side
  // of such a minimum (the minimum can move by a sample as u changes).
  void selectActive(const Eigen::VectorXd& g);
  // The threads of `team` (threads of them, calling one included) compute the Jacobian's
  // columns from now on; nullptr: the calling thread alone.
  void setTeam(de::BatchTeam* team, int threads);

  // Scratch of one thread's value(): the full search vector and every sampled margin.
  struct Workspace {
    Eigen::VectorXd u, g, c;
  };
  // value() with the scratch of `w`.
  bool valueWith(Workspace& w, const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) const;

  const JumpModel& model_;
  Eigen::VectorXd u0_;
  std::vector<Workspace> work_;  // one per team thread; [0] also serves value()
  de::BatchTeam* team_ = nullptr;
  std::vector<int> free_, active_, residuals_;
  bool apex_ = false;
  PolishGoal goal_ = PolishGoal::MeetTarget;
  int m_ = 0;
  Eigen::VectorXd xl_, xu_, cl_, cu_;
  double best_f_ = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_x_;
};

}  // namespace wj::planner
