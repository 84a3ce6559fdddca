#ifndef AQS_TESTING_ELEMENT_STATES_H_
#define AQS_TESTING_ELEMENT_STATES_H_

#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {
namespace testing {

// A named (F, S) pair for derivative tests.
struct ElementState {
  std::string name;
  Eigen::Matrix3d f;
  Eigen::Matrix3d s;
};

// A uniformly random rotation.
Eigen::Matrix3d RandomRotation(std::mt19937* rng);

// States covering what the solvers meet: near rest, random deformations, large
// rotations, compression (indefinite dP/dF), near-degenerate polar decompositions
// (sigma_1 + sigma_2 small, relative gap >= 1e-4), inverted elements (det F < 0),
// non-trivial actuations (anisotropic, sheared, one negative eigenvalue), G = F S a
// rotation (three singular values 1) and two nearly repeated positive singular values:
// 9 states per random_count.
std::vector<ElementState> DerivativeTestStates(int random_count, unsigned seed);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_ELEMENT_STATES_H_
