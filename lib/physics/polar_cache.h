#ifndef AQS_PHYSICS_POLAR_CACHE_H_
#define AQS_PHYSICS_POLAR_CACHE_H_

#include <vector>

#include <Eigen/Core>

#include "physics/actuation.h"
#include "physics/rotation_variant_svd.h"

namespace aqs {

// The rotation-variant SVDs of G_e = F_e(x) S_e(a), one per element, at one state (x, a),
// so that the energy, its gradient, the stiffness and the actuation derivatives at the
// same state share one 3x3 SVD per element (the SVD is most of their cost). A Newton
// step assembles the stiffness at the point whose energy and gradient its line search
// just evaluated, and the adjoint of training and fitting differentiates at the
// equilibrium the solve ended on: both find the SVDs here.
//
// ShapeTargetModel::EnergyAndGradient fills it; readers take it only where x and a are
// bit for bit the state it was filled at (Matches). Memory: BytesFor, about 220 bytes
// per element with the copies of x and a (about 51 MB at 232,635 elements). Not
// thread-safe: one per solver.
class PolarCache {
 public:
  // True if the cache holds every element's SVD at exactly (x, a).
  bool Matches(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
               const Eigen::Ref<const ActuationMatrix>& a) const;
  // `cache` if it is non-null and matches (x, a), else nullptr: what readers pass on.
  static const PolarCache* IfMatches(const PolarCache* cache,
                                     const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                     const Eigen::Ref<const ActuationMatrix>& a) {
    return cache != nullptr && cache->Matches(x, a) ? cache : nullptr;
  }

  // Starts filling at (x, a) for num_elements elements: the cache matches nothing until
  // Finish. Between the two, Store may be called concurrently for distinct elements.
  void Begin(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
             const Eigen::Ref<const ActuationMatrix>& a, int num_elements);
  void Store(int e, const RotationVariantSvd& svd) { svd_[e] = svd; }
  void Finish() { valid_ = true; }

  // Element e's SVD (only after Matches returned true).
  const RotationVariantSvd& svd(int e) const { return svd_[e]; }

  // Forgets the state (e.g. after a change of the model's rest shape or stiffness).
  void Clear() { valid_ = false; }

  // The bytes a filled cache takes for a mesh of this size (its SVDs and copies of x, a).
  static double BytesFor(int num_vertices, int num_elements) {
    return static_cast<double>(sizeof(RotationVariantSvd) + 6 * sizeof(double)) * num_elements +
           3.0 * sizeof(double) * num_vertices;
  }

 private:
  bool valid_ = false;
  Eigen::Matrix3Xd x_;
  ActuationMatrix a_;
  std::vector<RotationVariantSvd> svd_;
};

}  // namespace aqs

#endif  // AQS_PHYSICS_POLAR_CACHE_H_
