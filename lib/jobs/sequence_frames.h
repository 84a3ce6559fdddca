#ifndef AQS_JOBS_SEQUENCE_FRAMES_H_
#define AQS_JOBS_SEQUENCE_FRAMES_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fit/fit_target.h"

namespace aqs {

struct FitSequenceOptions;  // jobs/fit_sequence.h

// One frame's target, read and checked.
struct SequenceFrame {
  std::string path, name, kind;
  std::string origin;  // where it was listed ("list.txt:3") or the path
  FitTarget target;            // markers and poses
  Eigen::Matrix3Xd cloud;      // points
  FitTarget landmarks;         // points with FitSequenceOptions::landmarks (else empty)
};

// Resolves and reads the frames of `options.sequence` (and `options.landmarks`, at most
// `options.max_frames`, of `options.target_kind`) for a model whose neutral surface has
// the vertices `neutral` (3 x num_surface_vertices). Errors (false, *error) name the
// file and line: no frames, a missing file, an unreadable target (markers: repeated or
// out-of-range vertices at path:line; scans: no points), a target far from the model
// (another unit or frame: geometry/points_near_model.h), kinds that differ from the
// first frame's, a pose with another vertex count, two frames with the same name; with
// landmarks, a sequence that is not of point clouds, another number of landmark files
// than frames, an unreadable landmarks file.
bool ReadSequenceFrames(const FitSequenceOptions& options, const Eigen::Matrix3Xd& neutral,
                        std::vector<SequenceFrame>* frames, std::string* error);

// What frame's fit depends on of its target, as read: its kind, the target's points,
// vertices, weights, normals and tangential weight, the cloud and the landmarks (so a
// file rewritten with other numbers differs, one only reformatted does not).
uint64_t FrameTargetFingerprint(const SequenceFrame& frame);

}  // namespace aqs

#endif  // AQS_JOBS_SEQUENCE_FRAMES_H_
