#pragma once
/// @file DE variation operators (mutation strategies, binomial crossover with bound repair) and
/// the samplers of the initial population. Private to the solver.

#include <vector>

#include "planner/de/differential_evolution.h"
#include "random.h"

namespace wj::planner::de {

/// Box bounds of a problem, checked, with the indices of the variables that are not fixed.
struct Box {
  Eigen::VectorXd lower;
  Eigen::VectorXd upper;
  std::vector<int> free;  ///< indices j with lower(j) < upper(j)
};

/// What a mutation strategy may read: the current population and its ranking, and the JADE
/// archive of replaced parents (used by CurrentToPBest1Bin only).
struct MutationInput {
  const Eigen::MatrixXd& population;  ///< one individual per column
  const std::vector<int>& ranking;    ///< population indices, best first
  const Eigen::MatrixXd& archive;     ///< replaced parents, one per column
  int archive_size = 0;               ///< number of valid archive columns
  int pbest_count = 1;                ///< size of the p-best pool for CurrentToPBest1Bin
};

/// Writes the mutant (donor) vector of target `i` with scale factor F into `mutant`.
using MutationFunction = void (*)(const MutationInput& in, int i, double F, Random& rng,
                                  Eigen::Ref<Eigen::VectorXd> mutant);

/// v = x_r1 + F (x_r2 - x_r3) (Storn and Price 1997).
void mutateRand1(const MutationInput& in, int i, double F, Random& rng,
                 Eigen::Ref<Eigen::VectorXd> mutant);
/// v = x_best + F (x_r1 - x_r2) (Storn and Price 1997).
void mutateBest1(const MutationInput& in, int i, double F, Random& rng,
                 Eigen::Ref<Eigen::VectorXd> mutant);
/// v = x_i + F (x_best - x_i) + F (x_r1 - x_r2) (Storn and Price 1997).
void mutateCurrentToBest1(const MutationInput& in, int i, double F, Random& rng,
                          Eigen::Ref<Eigen::VectorXd> mutant);
/// v = x_r1 + F (x_r2 - x_r3) + F (x_r4 - x_r5) (Storn and Price 1997).
void mutateRand2(const MutationInput& in, int i, double F, Random& rng,
                 Eigen::Ref<Eigen::VectorXd> mutant);
/// v = x_i + F (x_pbest - x_i) + F (x_r1 - x~_r2), x~_r2 from population and archive (JADE).
void mutateCurrentToPBest1(const MutationInput& in, int i, double F, Random& rng,
                           Eigen::Ref<Eigen::VectorXd> mutant);

/// The mutation function of a strategy.
MutationFunction mutationFor(Strategy strategy);

/// Binomial crossover of `target` and `mutant` into `trial`, with one guaranteed mutant coordinate
/// among the free variables; an out-of-box mutant coordinate is reset to the midpoint between the
/// target's coordinate and the violated bound (JADE, Zhang and Sanderson 2009); fixed variables
/// keep the target's value.
void crossoverBinomial(const Eigen::Ref<const Eigen::VectorXd>& target,
                       const Eigen::Ref<const Eigen::VectorXd>& mutant, double CR, const Box& box,
                       Random& rng, Eigen::Ref<Eigen::VectorXd> trial);

/// Fills every column of `x` with an independent uniform sample of the box.
void sampleUniform(const Box& box, Random& rng, Eigen::Ref<Eigen::MatrixXd> x);

/// Fills the columns of `x` with a Latin hypercube sample: in every dimension each of the
/// x.cols() equal strata holds exactly one sample (McKay, Beckman and Conover 1979).
void sampleLatinHypercube(const Box& box, Random& rng, Eigen::Ref<Eigen::MatrixXd> x);

/// Writes the opposite point lower + upper - x of each column of `x` into `opposite`, clipped to
/// the box (Rahnamayan, Tizhoosh and Salama 2008).
void oppositePoints(const Box& box, const Eigen::Ref<const Eigen::MatrixXd>& x,
                    Eigen::Ref<Eigen::MatrixXd> opposite);

}  // namespace wj::planner::de
