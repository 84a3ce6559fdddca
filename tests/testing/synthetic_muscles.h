#ifndef AQS_TESTING_SYNTHETIC_MUSCLES_H_
#define AQS_TESTING_SYNTHETIC_MUSCLES_H_

#include <vector>

#include <Eigen/Core>

#include "model/active_model.h"

namespace aqs {
namespace testing {

// A soft bar (left end fixed) with three known "muscles": fibre contractions along
// the bar in its upper half and in its lower half, and along a diagonal fibre in its
// front half (which twists it). A pose is the equilibrium for activations m in
// [0, max_activation]^3 (muscle k's elements get S = (1 - m_k) f f^T + (1 + m_k / 2)
// (I - f f^T)), simulated with the project's solver; the "captured" surface is the
// bar's boundary. Returns a model with the training poses (no targets yet) and the
// held-out surfaces.
struct SyntheticMuscles {
  ActiveModel model;
  std::vector<Eigen::Vector3d> train_activations, test_activations;
  std::vector<Eigen::Matrix3Xd> test_surfaces;
};

SyntheticMuscles MakeSyntheticMuscles(int num_train, int num_test, double max_activation,
                                      unsigned seed);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_SYNTHETIC_MUSCLES_H_
