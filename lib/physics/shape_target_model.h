#ifndef AQS_PHYSICS_SHAPE_TARGET_MODEL_H_
#define AQS_PHYSICS_SHAPE_TARGET_MODEL_H_

#include <vector>

#include <Eigen/Core>

#include "mesh/tet_mesh.h"
#include "physics/actuation.h"
#include "physics/element_geometry.h"
#include "physics/polar_cache.h"
#include "physics/shape_target_element.h"

namespace aqs {

// A tet mesh with shape-targeting material: the total energy
//
//   E(x, a) = sum_e V_e mu_e min_R ||F_e(x) - R S_e||^2
//
// of vertex positions x (3 x num_vertices) and actuations a (6 x num_elements, see
// physics/actuation.h), with its first derivatives. Immutable after construction and
// safe to share between threads.
class ShapeTargetModel {
 public:
  // `mesh` must have elements of non-zero, finite rest volume (CHECKed here: det Dm != 0;
  // either orientation is taken, the energy does not depend on it). ValidateTetMesh's
  // stricter checks (orientation, near-degenerate elements) are the caller's to make on
  // meshes read from files. `mu` holds one stiffness (> 0) per element.
  ShapeTargetModel(const TetMesh& mesh, const Eigen::VectorXd& mu);
  // Homogeneous stiffness mu for every element.
  ShapeTargetModel(const TetMesh& mesh, double mu);

  int num_vertices() const { return num_vertices_; }
  int num_elements() const { return static_cast<int>(tets_.cols()); }
  const Eigen::Matrix4Xi& tets() const { return tets_; }
  const Eigen::Matrix3Xd& rest_positions() const { return rest_positions_; }
  const ElementRestShape& rest_shape(int e) const { return rest_shapes_[e]; }
  const Eigen::Matrix<double, 3, 4>& gradient_weights(int e) const { return weights_[e]; }
  double mu(int e) const { return mu_[e]; }
  const Eigen::VectorXd& mu() const { return mu_; }
  // sum_e V_e
  double total_volume() const { return total_volume_; }
  // sum_e mu_e V_e: the energy of the body under unit strain mismatch (an energy scale).
  double stiffness_volume() const { return stiffness_volume_; }
  // A force scale: 2 * mean_e(mu_e V_e^(2/3)), the magnitude of the nodal force of an
  // element under unit strain. Solver force tolerances are relative to it.
  double force_scale() const { return force_scale_; }

  // Positions and actuations are passed as Eigen::Ref so that matrices and Maps (for
  // example a solver's state) are read in place.
  using PositionsRef = Eigen::Ref<const Eigen::Matrix3Xd>;
  using ActuationRef = Eigen::Ref<const ActuationMatrix>;

  // F_e at positions x.
  Eigen::Matrix3d DeformationGradient(const PositionsRef& x, int e) const;
  // The element's derivative helper at (F_e(x), S_e(a), mu_e). With a non-null `cache`,
  // which must match (x, a) (PolarCache::Matches), its SVD is read there.
  ShapeTargetElement Element(const PositionsRef& x, const ActuationRef& a, int e,
                             const PolarCache* cache = nullptr) const;

  // E(x, a).
  double Energy(const PositionsRef& x, const ActuationRef& a, int num_threads = 1) const;
  // dE/dx (3 x num_vertices; the nodal forces are its negative). Returns E. With a
  // non-null `cache`: its SVDs are used if it matches (x, a), else it is filled at (x, a).
  double EnergyAndGradient(const PositionsRef& x, const ActuationRef& a,
                           Eigen::Matrix3Xd* gradient, int num_threads = 1,
                           PolarCache* cache = nullptr) const;
  // dE/da at fixed x (6 x num_elements, column e: V_e times
  // ShapeTargetElement::EnergyActuationGradient, in the order of physics/actuation.h,
  // off-diagonal entries counted twice). At an equilibrium x*(a) this is also the total
  // derivative of the equilibrium energy E(x*(a), a) (dE/dx = 0 there). Returns E. With
  // a non-null `cache` that matches (x, a), its SVDs are read there.
  double EnergyActuationGradient(const PositionsRef& x, const ActuationRef& a,
                                 ActuationMatrix* gradient, int num_threads = 1,
                                 const PolarCache* cache = nullptr) const;

 private:
  int num_vertices_;
  Eigen::Matrix4Xi tets_;
  Eigen::Matrix3Xd rest_positions_;
  std::vector<ElementRestShape> rest_shapes_;
  std::vector<Eigen::Matrix<double, 3, 4>> weights_;
  Eigen::VectorXd mu_;
  double total_volume_ = 0.0;
  double stiffness_volume_ = 0.0;
  double force_scale_ = 0.0;
};

}  // namespace aqs

#endif  // AQS_PHYSICS_SHAPE_TARGET_MODEL_H_
