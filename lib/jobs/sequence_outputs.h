#ifndef AQS_JOBS_SEQUENCE_OUTPUTS_H_
#define AQS_JOBS_SEQUENCE_OUTPUTS_H_

// The outputs of a sequence fit (jobs/fit_sequence.h) and how a rerun resumes from
// them: frames.csv's rows, and a fitted frame as one block of doubles (what a rank
// sends to rank 0, which alone writes). Internal to jobs/.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "fit/latent_fit.h"
#include "jobs/sequence_frames.h"
#include "model/active_model.h"
#include "geometry/rigid_transform.h"

namespace aqs {

// frames.csv's header for `model`: 14 columns (frame, name, kind, points, used_points,
// matched_fraction, mean_error, rms_error, max_error, iterations, seconds, converged,
// start, factorizations), then z1..zd, then <bone>_rx, ry, rz, tx, ty, tz per bone.
// converged: 1 the fit met its tolerance, 0 it stopped at its iteration limit, -1 the
// frame could not be fitted (independent frames only: its equilibrium could not be
// computed, no start reached it, or the fit's minimizer failed): then it has no OBJ, its
// errors, latent and bone motions are "nan" (and so is its column of latents.bin), and
// start is "none" if no start was chosen.
std::string SequenceCsvHeader(const ActiveModel& model);

// A frame found done in an earlier run: its CSV row as written, its latent (d) and its
// bones' motions.
struct DoneFrame {
  std::string line;
  int line_number = 0;  // in frames.csv
  Eigen::VectorXd latent;
  std::vector<RigidTransform> bones;
  bool failed = false;  // converged -1: could not be fitted (latent and bones: none)
};

// Reads the frames already done from `csv` (output_dir/frames.csv; none if it does not
// exist): its rows in order, frame 0 first, while the row's name is the frame's and
// its OBJ exists in output_dir (from the first frame without it the run is redone; a
// frame that could not be fitted, converged -1, has none and is done).
// Errors (false, *error at csv:line): a header for another model, rows of other frames
// or another column count (the folder holds another run), a figure, latent or bone
// number that is not a finite number (a damaged file).
bool ReadFramesDone(const std::string& csv, const std::string& output_dir,
                    const ActiveModel& model, const std::vector<SequenceFrame>& frames,
                    std::vector<DoneFrame>* done, std::string* error);

// output_dir/targets.txt, written by every run before it fits: per frame of the sequence
// (as read), one line "<name> <fingerprint>" (FrameTargetFingerprint, hexadecimal).
std::string SequenceTargetsText(const std::vector<SequenceFrame>& frames);

// How many of the first `num_done` frames were fitted to the targets they have now:
// the length of the run of leading lines `recorded` (an earlier run's targets.txt) shares
// with `current` (this run's), at most num_done. A frame whose target file was rewritten
// after it was fitted, and the frames after it, are fitted again.
int FramesOfSameTargets(const std::string& recorded, const std::string& current, int num_done);

// A fitted frame as one block of doubles: kFrameScalars numbers (used points, matched
// fraction, mean, rms and max error, iterations, seconds, converged, start,
// factorizations), the latent (d), the bones' motion parameters (6 per bone, as
// BoneTransformToParameters), the surface (3 x ns, column-major). The start is -2 for
// "previous", -1 for "given", else the training pose's index.
constexpr int kFrameScalars = 10;

// The converged value of a block (and of frames.csv) for a frame that could not be
// fitted.
constexpr double kFrameFailed = -1.0;

// Numbers in a block for latent size d, nb bones and ns surface vertices.
int FrameBlockSize(int d, int nb, int ns);

// `fit` (started from `start`: "previous", "given" or a training pose's name; fitted in
// `seconds`) as a block, FrameBlockSize(...) numbers for `model`.
void PackFrameBlock(const ActiveModel& model, const LatentFitResult& fit,
                    const std::string& start, double seconds, std::vector<double>* block);

// The block of a frame that could not be fitted: what `fit` counted (iterations,
// factorizations; started from `start`, "" if none was chosen) in `seconds`, converged
// kFrameFailed, and NaN for the errors, latent, bones and surface.
void PackFailedFrameBlock(const ActiveModel& model, const LatentFitResult& fit,
                          const std::string& start, double seconds, std::vector<double>* block);

// Whether block `b` is of a frame that could not be fitted.
inline bool BlockFailed(const double* b) { return b[7] == kFrameFailed; }

// Frame f's row of frames.csv (no newline) from its block `b`.
std::string FrameCsvRow(const ActiveModel& model, int f, const SequenceFrame& frame,
                        const double* b);

// The latent of block `b` (d numbers) and its surface (3 x ns).
Eigen::Map<const Eigen::VectorXd> BlockLatent(const ActiveModel& model, const double* b);
Eigen::Map<const Eigen::Matrix3Xd> BlockSurface(const ActiveModel& model, const double* b);

}  // namespace aqs

#endif  // AQS_JOBS_SEQUENCE_OUTPUTS_H_
