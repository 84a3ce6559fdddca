#ifndef AQS_EVAL_HELD_OUT_OVERLAP_H_
#define AQS_EVAL_HELD_OUT_OVERLAP_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// A held-out pose that is (nearly) one of the training poses: not held out at all (the
// same file twice, or the mirror image of a training pose under prepare's
// --mirror_poses, which is the other side's expression on a symmetric face).
struct HeldOutOverlap {
  int test = -1;       // index into the held-out poses
  int training = -1;   // the nearest training pose
  double distance = 0.0;  // mean vertex distance between the two
  double motion = 0.0;    // the held-out pose's mean vertex distance from the neutral
};

// For each held-out surface (3 x n each, the neutral's vertex order), the nearest
// training surface by mean vertex distance over `vertices` (all n if empty); reported
// where that distance is below `fraction` of the held-out pose's own mean distance from
// the neutral (poses that do not move are never reported). Order: by held-out index.
std::vector<HeldOutOverlap> FindHeldOutOverlaps(const Eigen::Matrix3Xd& neutral,
                                                const std::vector<Eigen::Matrix3Xd>& training,
                                                const std::vector<Eigen::Matrix3Xd>& held_out,
                                                const std::vector<int>& vertices,
                                                double fraction = 0.05);

}  // namespace aqs

#endif  // AQS_EVAL_HELD_OUT_OVERLAP_H_
