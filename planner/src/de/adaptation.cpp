#include "adaptation.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace wj::planner::de {
namespace {

/// Adaptation::None: the settings' F and CR for every trial.
class FixedParameters final : public ParameterControl {
 public:
  explicit FixedParameters(const Settings& settings) : fixed_{settings.F, settings.CR} {}
  ControlParameters sample(int /*i*/, Random& /*rng*/) override { return fixed_; }
  void select(int /*i*/, const ControlParameters& /*used*/, bool /*replaced*/,
              double /*improvement*/) override {}

 private:
  ControlParameters fixed_;
};

/// jDE (Brest, Greiner, Boskovic, Mernik and Zumer 2006): every individual carries its
/// own F and CR. For each trial, with probability tau1 F is redrawn as F_l + rand * F_u (so in
/// [0.1, 1.0]); with probability tau2 CR is redrawn as rand in [0, 1]. The new values survive only
/// if the trial is selected.
class JdeParameters final : public ParameterControl {
 public:
  JdeParameters(const Settings& settings, int np)
      : individual_(static_cast<std::size_t>(np), ControlParameters{settings.F, settings.CR}) {}

  ControlParameters sample(int i, Random& rng) override {
    ControlParameters p = individual_[static_cast<std::size_t>(i)];
    if (rng.uniform() < kTau1) p.F = kFLower + rng.uniform() * kFUpper;
    if (rng.uniform() < kTau2) p.CR = rng.uniform();
    return p;
  }

  void select(int i, const ControlParameters& used, bool replaced,
              double /*improvement*/) override {
    if (replaced) individual_[static_cast<std::size_t>(i)] = used;
  }

 private:
  static constexpr double kTau1 = 0.1;
  static constexpr double kTau2 = 0.1;
  static constexpr double kFLower = 0.1;
  static constexpr double kFUpper = 0.9;
  std::vector<ControlParameters> individual_;
};

/// SHADE (Tanabe and Fukunaga 2013): H-slot success-history memories M_F and M_CR. Each trial picks
/// a random slot r: CR ~ N(M_CR[r], 0.1) clipped to [0, 1], F ~ Cauchy(M_F[r], 0.1) redrawn while
/// <= 0 and truncated to 1. At the end of a generation with successes (strict improvements), slot
/// k receives the weighted arithmetic mean of the successful CR and the weighted Lehmer mean of the
/// successful F, weights proportional to the improvements |f(u) - f(x)|; k advances cyclically.
class ShadeParameters final : public ParameterControl {
 public:
  ShadeParameters(const Settings& settings, int np)
      : memory_F_(memorySize(settings, np), settings.F),
        memory_CR_(memorySize(settings, np), settings.CR) {
    success_F_.reserve(static_cast<std::size_t>(np));
    success_CR_.reserve(static_cast<std::size_t>(np));
    improvement_.reserve(static_cast<std::size_t>(np));
  }

  ControlParameters sample(int /*i*/, Random& rng) override {
    const auto r = static_cast<std::size_t>(rng.index(static_cast<int>(memory_F_.size())));
    ControlParameters p;
    p.CR = std::clamp(rng.normal(memory_CR_[r], 0.1), 0.0, 1.0);
    do {
      p.F = rng.cauchy(memory_F_[r], 0.1);
    } while (p.F <= 0.0);
    p.F = std::min(p.F, 1.0);
    return p;
  }

  void select(int /*i*/, const ControlParameters& used, bool replaced,
              double improvement) override {
    if (!replaced || !(improvement > 0.0)) return;
    success_F_.push_back(used.F);
    success_CR_.push_back(used.CR);
    improvement_.push_back(improvement);
  }

  void endGeneration() override {
    if (success_F_.empty()) return;
    normaliseWeights();
    double mean_CR = 0.0;
    double sum_F2 = 0.0;
    double sum_F = 0.0;
    for (std::size_t s = 0; s < success_F_.size(); ++s) {
      mean_CR += improvement_[s] * success_CR_[s];
      sum_F2 += improvement_[s] * success_F_[s] * success_F_[s];
      sum_F += improvement_[s] * success_F_[s];
    }
    memory_CR_[next_] = mean_CR;
    memory_F_[next_] = sum_F2 / sum_F;  // sum_F > 0: every successful F is in (0, 1]
    next_ = (next_ + 1) % memory_F_.size();
    success_F_.clear();
    success_CR_.clear();
    improvement_.clear();
  }

 private:
  static std::size_t memorySize(const Settings& settings, int np) {
    return static_cast<std::size_t>(settings.shade_memory_size > 0 ? settings.shade_memory_size
                                                                   : np);
  }

  /// Turns improvements into weights that sum to 1. An infinite improvement (a trial that repaired
  /// an infinite-cost parent) dominates every finite one: the infinite ones share the weight.
  void normaliseWeights() {
    const bool any_infinite = std::any_of(improvement_.begin(), improvement_.end(),
                                          [](double d) { return std::isinf(d); });
    if (any_infinite) {
      for (double& d : improvement_) d = std::isinf(d) ? 1.0 : 0.0;
    }
    double total = 0.0;
    for (const double d : improvement_) total += d;
    for (double& d : improvement_) d /= total;
  }

  std::vector<double> memory_F_;
  std::vector<double> memory_CR_;
  std::size_t next_ = 0;
  std::vector<double> success_F_;
  std::vector<double> success_CR_;
  std::vector<double> improvement_;
};

}  // namespace

std::unique_ptr<ParameterControl> makeParameterControl(const Settings& settings, int np) {
  switch (settings.adaptation) {
    case Adaptation::None:
      return std::make_unique<FixedParameters>(settings);
    case Adaptation::JDE:
      return std::make_unique<JdeParameters>(settings, np);
    case Adaptation::SHADE:
      return std::make_unique<ShadeParameters>(settings, np);
  }
  return std::make_unique<FixedParameters>(settings);  // unreachable: validate() rejects others
}

}  // namespace wj::planner::de
