#ifndef AQS_CONTACT_OBSTACLE_H_
#define AQS_CONTACT_OBSTACLE_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/rigid_transform.h"
#include "geometry/surface_features.h"
#include "geometry/triangle_bvh.h"
#include "geometry/winding_number.h"

namespace aqs {

// A closed feature (triangle, edge or vertex) of an obstacle near a point, for sums over
// features (Obstacle::FeaturesWithin, contact/obstacle_penalty.h).
struct FeatureDistance {
  double distance = 0.0;  // unsigned, from the point to the feature's closest point
  // The unit vector from the closest point to the point (the gradient of `distance`);
  // zero on the feature (distance <= 1e-12), where it has none.
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  double weight = 1.0;  // 1 for triangles, SurfaceFeatures' weight for edges and vertices
  // Where the closest point lies: 0 at a point (a vertex, an edge's end, a triangle's
  // corner), 1 inside a segment (an edge, a triangle's side) running along the unit
  // `tangent`, 2 inside a triangle. It sets the distance's curvature
  // (FeatureDistanceHessian).
  int closest_dimension = 2;
  Eigen::Vector3d tangent = Eigen::Vector3d::Zero();
};

// The Hessian of a feature's unsigned distance with respect to the point (3 x 3): (I -
// u u^T) / d at a point, (I - u u^T - e e^T) / d along a segment (u = direction, e =
// tangent, d = distance), 0 inside a triangle; 0 when d <= 1e-12 (where the distance is
// not differentiable). With min_distance > 0, d in the division is at least
// min_distance (a bounded curvature, exact where d >= min_distance).
Eigen::Matrix3d FeatureDistanceHessian(const FeatureDistance& feature, double min_distance = 0.0);

// A rigid obstacle at one placement: a closed triangle surface (one shell; closed shells
// that overlap, as the teeth of a dental model, are one obstacle each: SplitIntoShells)
// with its signed distance: positive outside, negative inside (inside by winding number).
class Obstacle {
 public:
  // vertices: 3 x N at the placement; triangles: 3 x M, consistently oriented, outward
  // or inward (the sign of the enclosed volume, about the triangles' mean corner, says
  // which), closed (the inside test is a winding number; small holes are tolerated).
  Obstacle(std::string name, const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles);

  const std::string& name() const { return name_; }
  const Eigen::Matrix3Xd& vertices() const { return vertices_; }
  const Eigen::Matrix3Xi& triangles() const { return triangles_; }

  // The signed distance of p and its gradient (the unit vector from the closest surface
  // point to p, flipped inside: it points out of the obstacle). Points outside farther
  // than max_distance (when finite) return +max_distance with a zero gradient, without a
  // full search; points inside always get their whole (negative) distance.
  double SignedDistance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                        double max_distance = std::numeric_limits<double>::infinity()) const;

  // The features of the surface nearer to p than `reach` (> 0) with a nonzero
  // weight (geometry/surface_features.h), appended to *features: the triangles in
  // ascending order, then their edges, then their vertices (each once, ascending). A
  // feature within reach always belongs to a triangle within reach.
  void FeaturesWithin(const Eigen::Vector3d& p, double reach,
                      std::vector<FeatureDistance>* features) const;

 private:
  std::string name_;
  Eigen::Matrix3Xd vertices_;
  Eigen::Matrix3Xi triangles_;
  FastWindingNumber winding_;  // over all triangles: the inside test
  // +1 if the triangles face outward (positive enclosed volume), -1 if inward: the
  // winding number inside is then -1, and the triangles' normals point in.
  double orientation_ = 1.0;
  TriangleBvh bvh_;
  SurfaceFeatures features_;
  Eigen::Vector3d lower_ = Eigen::Vector3d::Zero(), upper_ = Eigen::Vector3d::Zero();  // box
};

// A rigid obstacle that moves with one of a model's bones, or stays: its surface at rest.
struct MovingObstacle {
  std::string name;
  Eigen::Matrix3Xd vertices;   // 3 x N, at rest
  Eigen::Matrix3Xi triangles;  // 3 x M
  int bone = -1;               // index of the bone it moves with; -1: static

  // The obstacle at the placement of `bones` (bones[bone] applied when bone >= 0;
  // CHECKs that the bone exists).
  std::unique_ptr<Obstacle> Place(const std::vector<RigidTransform>& bones) const;
};

// The connected components of `obstacle`'s surface (triangles sharing a vertex), each an
// obstacle of its own moving with the same bone, named "<name> shell k" (k from 1, in the
// order of their smallest vertex), its vertices renumbered; `obstacle` itself if it has
// one. Closed shells that overlap (teeth) are not one closed surface: measured as one, a
// point inside an overlap got the distance to a face buried in the other shell, and the
// penalty held it there.
std::vector<MovingObstacle> SplitIntoShells(const MovingObstacle& obstacle);

// A rigid obstacle as specified by users: a surface file, optionally only the triangles
// whose vertices all lie in a vertex range (e.g. the lower teeth of a file with both
// jaws), optionally moving with a bone of the model.
struct ObstacleSpec {
  std::string path;
  int first_vertex = 0;
  int end_vertex = -1;  // -1: all
  std::string bone;     // empty: static
};

// Parses "path [vertices=a:b] [bone=name]" items separated by commas, fields separated by
// whitespace; a field in double quotes may hold spaces and commas ("My Scans/teeth.obj").
// Errors (false, *error naming the item): an empty item or path, a quote not closed, a
// key given twice, an unknown key or a second field without '=', a bad range, bone= with
// no name.
bool ParseObstacleSpecs(const std::string& text, std::vector<ObstacleSpec>* specs,
                        std::string* error);

// Reads the obstacle surfaces (OBJ) of `specs`, keeping the requested triangles;
// vertices stay in the file's numbering. Errors name the file.
bool ReadObstacleSurfaces(const std::vector<ObstacleSpec>& specs,
                          std::vector<Eigen::Matrix3Xd>* vertices,
                          std::vector<Eigen::Matrix3Xi>* triangles, std::string* error);

}  // namespace aqs

#endif  // AQS_CONTACT_OBSTACLE_H_
