#include "testing/element_states.h"

#include <Eigen/Geometry>

namespace aqs {
namespace testing {

Eigen::Matrix3d RandomRotation(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Quaterniond q(normal(*rng), normal(*rng), normal(*rng), normal(*rng));
  q.normalize();
  return q.toRotationMatrix();
}

namespace {

Eigen::Matrix3d RandomMatrix(std::mt19937* rng, double scale) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::Matrix3d m;
  for (int i = 0; i < 9; ++i) m.data()[i] = scale * uniform(*rng);
  return m;
}

Eigen::Matrix3d RandomSymmetric(std::mt19937* rng, double scale) {
  const Eigen::Matrix3d m = RandomMatrix(rng, scale);
  return 0.5 * (m + m.transpose());
}

}  // namespace

std::vector<ElementState> DerivativeTestStates(int random_count, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<ElementState> states;
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  for (int i = 0; i < random_count; ++i) {
    const Eigen::Matrix3d r = RandomRotation(&rng);
    const Eigen::Matrix3d s = identity + RandomSymmetric(&rng, 0.3);
    states.push_back({"near_rest_" + std::to_string(i), r * (identity + RandomMatrix(&rng, 0.05)), s});
    states.push_back({"deformed_" + std::to_string(i), r * (identity + RandomMatrix(&rng, 0.6)), s});
    states.push_back({"rotated_" + std::to_string(i),
                      RandomRotation(&rng) * (identity + RandomMatrix(&rng, 0.2)),
                      identity + RandomSymmetric(&rng, 0.2)});
    states.push_back({"compressed_" + std::to_string(i),
                      r * (0.3 * identity + RandomMatrix(&rng, 0.1)), s});
    // Near-degenerate polar decomposition of G = F S: sigma = (a, b, -(b - gap)).
    {
      const double a = 1.5, b = 0.6, gap = 1e-3 * (1 + i % 3);
      Eigen::Vector3d sigma(a, b, -(b - gap));
      const Eigen::Matrix3d g = RandomRotation(&rng) * sigma.asDiagonal() *
                                RandomRotation(&rng).transpose();
      states.push_back({"near_degenerate_" + std::to_string(i), g * s.inverse(), s});
    }
    // Inverted: det F < 0 but well separated singular values.
    {
      Eigen::Vector3d sigma(1.3, 0.9, -0.3);
      const Eigen::Matrix3d f = RandomRotation(&rng) * sigma.asDiagonal() *
                                RandomRotation(&rng).transpose();
      states.push_back({"inverted_" + std::to_string(i), f, s});
    }
    // Indefinite actuation (one negative eigenvalue) and strong anisotropy.
    {
      const Eigen::Matrix3d q = RandomRotation(&rng);
      const Eigen::Vector3d lambda(1.8, 0.4, -0.2);
      states.push_back({"indefinite_target_" + std::to_string(i),
                        r * (identity + RandomMatrix(&rng, 0.3)),
                        q * lambda.asDiagonal() * q.transpose()});
    }
    // G = F S a rotation: its three singular values 1 (the polar twists' U and V columns
    // are not unique there); with S != I the stress is not zero.
    states.push_back({"triple_" + std::to_string(i), RandomRotation(&rng) * s.inverse(), s});
    // Two nearly repeated positive singular values of G = F S.
    {
      const Eigen::Vector3d sigma(1.0 + 1e-9, 1.0, 0.7);
      const Eigen::Matrix3d g = RandomRotation(&rng) * sigma.asDiagonal() *
                                RandomRotation(&rng).transpose();
      states.push_back({"repeated_" + std::to_string(i), g * s.inverse(), s});
    }
  }
  return states;
}

}  // namespace testing
}  // namespace aqs
