#ifndef AQS_PREPARE_HALFWAY_POSES_H_
#define AQS_PREPARE_HALFWAY_POSES_H_

#include <ostream>
#include <string>

#include "model/active_model.h"

namespace aqs {

// Poses halfway to the training poses whose bones move (prepare's --halfway_poses). A
// bone turns on arcs: a decoder trained on a jaw opened all the way has no example of the
// skin's actuation on the way there, and a model fitted to a half-opened jaw (a blend of
// ICT expressions with jawOpen at 0.44) missed it by 0.036 cm where it fits the fully
// opened one at 0.026 (docs/results.md). The halfway pose of pose p has
//   surface   neutral + (surface_p - neutral) / 2 (a blend shape at weight 1/2),
//   bones     each bone's transform halfway along its screw motion
//             (InterpolateRigidTransform(T_p, 1/2): applied twice, it is T_p).
// (The rigid motion nearest the bone's vertices blended at 1/2, where the blended skin
// around the jaw puts it, was measured and not kept: docs/results.md.)
struct HalfwayOptions {
  bool enabled = false;
  // A pose gets a halfway pose when one of its bones moves one of its vertices farther
  // than this fraction of the simulation mesh's bounding-box diagonal; in (0, 1] (0 would
  // give one to a bone whose fitted motion is round-off).
  double min_bone_motion = 0.01;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// The largest distance any of bone b's vertices moves in training pose p:
// max over bone vertices v of |T_p(x_v) - x_v| at the mesh's rest positions.
double LargestBoneMotion(const ActiveModel& model, int bone, int pose);

// Appends to model->poses, after the given ones, the halfway pose (see HalfwayOptions)
// of every pose whose bones move (options.min_bone_motion), named "half_" + its name, and
// to every bone its halfway transform. Needs model->mesh, model->neutral and the bones'
// transforms, one per pose (CHECK); targets are not made here. Logs one line per pose it
// adds; *added receives their count. False with *error if a halfway pose's name is a
// given pose's.
bool AddHalfwayPoses(const HalfwayOptions& options, ActiveModel* model, int* added,
                     std::ostream& log, std::string* error);

}  // namespace aqs

#endif  // AQS_PREPARE_HALFWAY_POSES_H_
