#ifndef AQS_PREPARE_MIRROR_POSES_H_
#define AQS_PREPARE_MIRROR_POSES_H_

#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/rigid_transform.h"
#include "model/active_model.h"

namespace aqs {

// Left-right mirror images of the training poses (prepare's --mirror_poses), for a body
// whose rest surface is mirror-symmetric (a face): the model then trains on both sides of
// every pose. The mirror is the plane {x : x[axis] = plane}; its reflection is
// S(x) = M x + 2 plane e_axis, M = I - 2 e_axis e_axis^T.
struct MirrorOptions {
  // The axis normal to the mirror plane: 0 (x), 1 (y) or 2 (z); -1: no mirror images.
  int axis = -1;
  // Where the plane cuts the axis (model units).
  double plane = 0.0;
  // The largest distance from a neutral vertex's reflection to the nearest neutral
  // vertex, as a fraction of the neutral's bounding-box diagonal; a neutral less
  // symmetric than this is an error.
  double tolerance = 1e-3;
  // A pose whose image differs from it by less than this fraction of its own motion
  // (both as mean vertex distances) is symmetric already and gets no image.
  double same_fraction = 0.1;

  bool enabled() const { return axis >= 0; }
  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// The mirror map of a point set (3 x n): map[i] is the index of the point nearest to the
// reflection of point i. False with *error naming the point if that nearest point is
// farther than `tolerance` (model units) or if the map is not its own inverse (points
// closer together than the tolerance). The points go into a TriangleGrid
// (geometry/triangle_grid.h) of cells of the tolerance: O(n) for a surface's vertices.
bool MirrorVertexMap(const Eigen::Matrix3Xd& points, int axis, double plane, double tolerance,
                     std::vector<int>* map, std::string* error);

// The mirror image of a pose (3 x n, the neutral's vertex order): the neutral plus the
// reflected displacements of the mirror vertices,
//   image_i = neutral_i + M (pose_map[i] - neutral_map[i]),
// so the image of the neutral is the neutral even where it is not exactly symmetric.
Eigen::Matrix3Xd MirrorPoseSurface(const Eigen::Matrix3Xd& neutral, const Eigen::Matrix3Xd& pose,
                                   const std::vector<int>& map, int axis);

// The mirror image of a rigid motion T: S T S, the motion of the mirrored bone (rotation
// M R M, still proper; translation M R b + M t + b with b = 2 plane e_axis).
RigidTransform MirrorRigidTransform(const RigidTransform& transform, int axis, double plane);

// Appends to model->poses, after the given ones, the mirror image (MirrorPoseSurface) of
// each pose that is not symmetric already (options.same_fraction), named "mirror_" + its
// name; *sources receives, for each appended pose in order, the index of its source.
// Needs model->neutral; targets are not made here. Logs one line per pose. False with
// *error if the neutral is not symmetric (MirrorVertexMap) or an image's name is taken.
bool AddMirrorPoses(const MirrorOptions& options, ActiveModel* model, std::vector<int>* sources,
                    std::ostream& log, std::string* error);

// For the poses AddMirrorPoses appended (model->poses[first + k], k indexing sources),
// sets every bone's transform to the mirror image of its source pose's transform.
// Each bone must have a transform per pose (CHECK).
void MirrorBoneTransforms(const MirrorOptions& options, const std::vector<int>& sources,
                          int first, ActiveModel* model);

}  // namespace aqs

#endif  // AQS_PREPARE_MIRROR_POSES_H_
