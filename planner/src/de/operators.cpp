#include "operators.h"

#include <algorithm>
#include <initializer_list>
#include <numeric>

namespace wj::planner::de {
namespace {

/// A uniform index in [0, n) that differs from every index in `excluded` (rejection sampling).
int drawExcluding(Random& rng, int n, std::initializer_list<int> excluded) {
  for (;;) {
    const int r = rng.index(n);
    if (std::find(excluded.begin(), excluded.end(), r) == excluded.end()) return r;
  }
}

/// Coordinate j of the mutant after the JADE bound repair: a value below the lower bound becomes
/// (lower + parent) / 2, one above the upper bound (upper + parent) / 2 (JADE, Zhang and Sanderson
/// 2009; kept by SHADE, Tanabe and Fukunaga 2013).
double repaired(double value, double parent, double lower, double upper) {
  if (value < lower) return 0.5 * (lower + parent);
  if (value > upper) return 0.5 * (upper + parent);
  return value;
}

}  // namespace

void mutateRand1(const MutationInput& in, int i, double F, Random& rng,
                 Eigen::Ref<Eigen::VectorXd> mutant) {
  const int np = static_cast<int>(in.population.cols());
  const int r1 = drawExcluding(rng, np, {i});
  const int r2 = drawExcluding(rng, np, {i, r1});
  const int r3 = drawExcluding(rng, np, {i, r1, r2});
  const auto& x = in.population;
  mutant = x.col(r1) + F * (x.col(r2) - x.col(r3));
}

void mutateBest1(const MutationInput& in, int i, double F, Random& rng,
                 Eigen::Ref<Eigen::VectorXd> mutant) {
  const int np = static_cast<int>(in.population.cols());
  const int r1 = drawExcluding(rng, np, {i});
  const int r2 = drawExcluding(rng, np, {i, r1});
  const auto& x = in.population;
  mutant = x.col(in.ranking.front()) + F * (x.col(r1) - x.col(r2));
}

void mutateCurrentToBest1(const MutationInput& in, int i, double F, Random& rng,
                          Eigen::Ref<Eigen::VectorXd> mutant) {
  const int np = static_cast<int>(in.population.cols());
  const int r1 = drawExcluding(rng, np, {i});
  const int r2 = drawExcluding(rng, np, {i, r1});
  const auto& x = in.population;
  mutant = x.col(i) + F * (x.col(in.ranking.front()) - x.col(i)) + F * (x.col(r1) - x.col(r2));
}

void mutateRand2(const MutationInput& in, int i, double F, Random& rng,
                 Eigen::Ref<Eigen::VectorXd> mutant) {
  const int np = static_cast<int>(in.population.cols());
  const int r1 = drawExcluding(rng, np, {i});
  const int r2 = drawExcluding(rng, np, {i, r1});
  const int r3 = drawExcluding(rng, np, {i, r1, r2});
  const int r4 = drawExcluding(rng, np, {i, r1, r2, r3});
  const int r5 = drawExcluding(rng, np, {i, r1, r2, r3, r4});
  const auto& x = in.population;
  mutant = x.col(r1) + F * (x.col(r2) - x.col(r3)) + F * (x.col(r4) - x.col(r5));
}

void mutateCurrentToPBest1(const MutationInput& in, int i, double F, Random& rng,
                           Eigen::Ref<Eigen::VectorXd> mutant) {
  // JADE (Zhang and Sanderson 2009, eq. 4 with archive): x_pbest is drawn uniformly from the
  // 100p % best individuals, x_r1 from the population (r1 != i), x~_r2 from the union of the
  // population and the archive of recently replaced parents (r2 != i, r1).
  const int np = static_cast<int>(in.population.cols());
  const int pbest = in.ranking[static_cast<std::size_t>(rng.index(in.pbest_count))];
  const int r1 = drawExcluding(rng, np, {i});
  const int r2 = drawExcluding(rng, np + in.archive_size, {i, r1});
  const auto& x = in.population;
  if (r2 < np) {
    mutant = x.col(i) + F * (x.col(pbest) - x.col(i)) + F * (x.col(r1) - x.col(r2));
  } else {
    mutant = x.col(i) + F * (x.col(pbest) - x.col(i)) + F * (x.col(r1) - in.archive.col(r2 - np));
  }
}

MutationFunction mutationFor(Strategy strategy) {
  switch (strategy) {
    case Strategy::Rand1Bin:
      return &mutateRand1;
    case Strategy::Best1Bin:
      return &mutateBest1;
    case Strategy::CurrentToBest1Bin:
      return &mutateCurrentToBest1;
    case Strategy::Rand2Bin:
      return &mutateRand2;
    case Strategy::CurrentToPBest1Bin:
      return &mutateCurrentToPBest1;
  }
  return &mutateRand1;  // unreachable: Settings::validate() rejects other values
}

void crossoverBinomial(const Eigen::Ref<const Eigen::VectorXd>& target,
                       const Eigen::Ref<const Eigen::VectorXd>& mutant, double CR, const Box& box,
                       Random& rng, Eigen::Ref<Eigen::VectorXd> trial) {
  trial = target;
  if (box.free.empty()) return;
  // Storn and Price 1997: u_j = v_j if rand_j <= CR or j = j_rand, else x_j. j_rand is drawn among
  // the free variables so that the trial always differs from its target in a variable that can.
  const int j_rand =
      box.free[static_cast<std::size_t>(rng.index(static_cast<int>(box.free.size())))];
  for (const int j : box.free) {
    const double r = rng.uniform();
    if (j == j_rand || r < CR) {
      trial(j) = repaired(mutant(j), target(j), box.lower(j), box.upper(j));
    }
  }
}

void sampleUniform(const Box& box, Random& rng, Eigen::Ref<Eigen::MatrixXd> x) {
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    for (Eigen::Index j = 0; j < x.rows(); ++j) {
      const double lo = box.lower(j);
      const double hi = box.upper(j);
      x(j, c) = std::min(hi, lo + rng.uniform() * (hi - lo));
    }
  }
}

void sampleLatinHypercube(const Box& box, Random& rng, Eigen::Ref<Eigen::MatrixXd> x) {
  const int n = static_cast<int>(x.cols());
  std::vector<int> stratum(static_cast<std::size_t>(n));
  for (Eigen::Index j = 0; j < x.rows(); ++j) {
    // An independent random permutation of the strata per dimension (Fisher-Yates with our own
    // index draws; std::shuffle's algorithm is implementation-defined).
    std::iota(stratum.begin(), stratum.end(), 0);
    for (int k = n - 1; k > 0; --k) {
      std::swap(stratum[static_cast<std::size_t>(k)],
                stratum[static_cast<std::size_t>(rng.index(k + 1))]);
    }
    const double lo = box.lower(j);
    const double hi = box.upper(j);
    for (int c = 0; c < n; ++c) {
      const double u = (stratum[static_cast<std::size_t>(c)] + rng.uniform()) / n;
      x(j, c) = std::min(hi, lo + u * (hi - lo));
    }
  }
}

void oppositePoints(const Box& box, const Eigen::Ref<const Eigen::MatrixXd>& x,
                    Eigen::Ref<Eigen::MatrixXd> opposite) {
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    opposite.col(c) = (box.lower + box.upper - x.col(c)).cwiseMax(box.lower).cwiseMin(box.upper);
  }
}

}  // namespace wj::planner::de
