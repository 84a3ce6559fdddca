#ifndef ACTIVEQS_FIT_TARGET_SUBSET_H_
#define ACTIVEQS_FIT_TARGET_SUBSET_H_

#include "fit/latent_fit.h"

namespace aqs {

// The `count` points of `target` spread farthest apart over their target positions:
// greedy farthest-point sampling (Euclidean, in the model's units) that starts at the
// first point of positive weight and adds, each step, the point farthest from those
// chosen (ties: the lowest index). Points of zero weight are never chosen. Returns a
// target with those points (vertices, barycentric, positions, weights and normals
// copied, in the order chosen); the whole target when it has at most `count` usable
// points. Deterministic; O(count x num_points).
FitTarget FarthestPointSubset(const FitTarget& target, int count);

}  // namespace aqs

#endif  // ACTIVEQS_FIT_TARGET_SUBSET_H_
