#include "jobs/fit_sequence.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <set>
#include <sstream>

#include "dist/model_sharing.h"
#include "fit/chosen_start_fit.h"
#include "geometry/points_near_model.h"
#include "jobs/fit_job.h"
#include "jobs/model_pose.h"
#include "jobs/sequence_frames.h"
#include "jobs/sequence_outputs.h"
#include "mesh/mesh_io.h"
#include "model/model_fingerprint.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/input_file.h"
#include "util/matrix_io.h"
#include "util/number_format.h"
#include "util/option_checks.h"
#include "util/path_lock.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

std::string FormatSeconds(double s) {
  std::ostringstream out;
  if (s < 60) {
    out << std::fixed << std::setprecision(0) << s << " s";
  } else {
    out << static_cast<int>(s / 60) << " min " << static_cast<int>(std::fmod(s, 60.0)) << " s";
  }
  return out.str();
}

// Frames shared among ranks need independent frames.
bool CheckSharing(const FitSequenceOptions& options, std::string* error) {
  const Communicator* comm = options.communicator;
  if (comm == nullptr || comm->size() <= 1 || !options.warm_start) return true;
  *error = "a warm-started sequence (--sequence_warm_start, the default) fits frame after "
           "frame, each from the previous frame's result, and cannot be shared among " +
           std::to_string(comm->size()) +
           " ranks: give --sequence_warm_start=false to fit every frame on its own (shared "
           "among the ranks), or run one process";
  return false;
}

// Where this process stands among the ranks that share a sequence: one process, or
// FitSequenceOptions::communicator's ranks.
struct SequenceRanks {
  explicit SequenceRanks(const Communicator* c)
      : comm(c),
        distributed(c != nullptr && c->size() > 1),
        root(!distributed || c->is_root()),
        rank(distributed ? c->rank() : 0),
        size(distributed ? c->size() : 1) {}
  // `ok` on this rank -> ok on every rank (else false everywhere, with the first
  // failing rank's *error); one process: `ok`.
  bool Agree(bool ok, std::string* error) const {
    return distributed ? comm->Agree(ok, error) : ok;
  }
  const Communicator* comm;
  bool distributed, root;
  int rank, size;
};

// Every rank reads the targets (the same path on every machine); they must be rank 0's
// frames. False on every rank if any rank fails.
bool ReadFramesOnEveryRank(const FitSequenceOptions& options, const ActiveModel& model,
                           const SequenceRanks& ranks, std::vector<SequenceFrame>* frames,
                           std::string* error) {
  bool ok = ReadSequenceFrames(options, model.neutral.vertices, frames, error);
  if (!ranks.distributed) return ok;
  // The frames' names and targets (FrameTargetFingerprint): rank 0 records every frame's
  // fit as one of its own targets (frames.csv, targets.txt).
  std::vector<std::string> items;
  for (const SequenceFrame& f : *frames) {
    items.push_back(f.name + " " + FingerprintText(FrameTargetFingerprint(f)));
  }
  int root_count = 0;
  const int unlike = ranks.comm->FirstItemUnlikeRoot(items, &root_count);
  const int count = static_cast<int>(frames->size());
  if (ok && unlike >= 0) {
    std::string what;
    if (unlike >= count) {
      what = std::to_string(count) + " frames here, fewer than rank 0's " +
             std::to_string(root_count);
    } else if (unlike >= root_count) {
      what = std::to_string(count) + " frames here, more than rank 0's " +
             std::to_string(root_count) + " (from " + (*frames)[unlike].name + " on)";
    } else {
      what = "frame " + std::to_string(unlike) + " (" + (*frames)[unlike].name +
             ") differs from rank 0's (another target file at that path?)";
    }
    *error = options.sequence + ": " + what + ": every machine must hold the same sequence";
    ok = false;
  }
  return ranks.comm->Agree(ok, error);
}

// Rank 0 creates output_dir and reads the frames done there (*done; the other ranks'
// stays empty). False on every rank if it fails.
// What a sequence's frames depend on besides their targets (output_dir/key.txt): the
// model (prepared part and learned state) and every option that shapes a fit. (Not
// warm_start: a warm-started run may go on from an independent run's frames.)
std::string SequenceKey(const FitSequenceOptions& options, const ActiveModel& model,
                        const std::vector<SequenceFrame>& frames) {
  const FitStartOptions& s = options.start;
  std::ostringstream key;
  key << "model " << FingerprintText(ModelFingerprint(model)) << "\n"
      << "learned " << FingerprintText(LearnedStateFingerprint(model)) << "\n"
      << "target_kind " << options.target_kind << "\n"
      << "landmarks " << (options.landmarks.empty() ? "none" : "yes") << "\n"
      << "start " << s.training_poses << " " << s.retry_from_given << " " << s.mean_latent
      << "\n"
      << options.points.KeyText() << options.fit.KeyText();
  // Only when on, so that the keys of runs without it stay as they were.
  if (options.temporal_prior > 0) {
    key << "temporal_prior " << FormatDouble(options.temporal_prior) << "\n";
  }
  // Scan fits measure to the neutral's faces, which the model's fingerprint leaves out
  // (only for scans, so that other keys stay as they were).
  if (std::any_of(frames.begin(), frames.end(),
                  [](const SequenceFrame& f) { return f.kind == "points"; })) {
    key << "faces " << FacesFingerprint(model.neutral) << "\n";
  }
  return key.str();
}

// Whether a folder's key.txt, `stored`, is `key`, SequenceKey's: the same but for the
// landmarks line of keys written before 2026-12-06, which held the --landmarks spelling
// (now "yes": which files they are is in each frame's fingerprint, targets.txt).
bool SameSequenceKey(const std::string& stored, const std::string& key) {
  std::istringstream lines(stored);
  std::string line, normalized;
  while (std::getline(lines, line)) {
    if (line.rfind("landmarks ", 0) == 0 && line != "landmarks none") line = "landmarks yes";
    normalized += line + "\n";
  }
  return normalized == key;
}

// Opens the output folder (rank 0 takes its writers' lock, reads and writes; the ranks
// agree): the frames done
// by an earlier run of the same key, which must be this run's (key.txt; a folder with
// frames but no key.txt is an older version's run, taken as it is). Frames of another
// model or other options are refused, never mixed with this run's. Of the frames done,
// those before the first whose target changed since it was fitted (targets.txt; none
// recorded: an older version's run, all) are kept; *note then says which, and which
// temporary files of a killed run were removed, a line each (else empty).
bool OpenOutputFolder(const FitSequenceOptions& options, const ActiveModel& model,
                      const std::vector<SequenceFrame>& frames, const SequenceRanks& ranks,
                      PathLock* lock, std::vector<DoneFrame>* done, std::string* note,
                      std::string* error) {
  bool ok = true;
  if (ranks.root) {
    std::error_code code;
    fs::create_directories(options.output_dir, code);
    if (code) {
      *error = options.output_dir + ": cannot create the folder (" + code.message() + ")";
      ok = false;
    }
    // One run at a time writes into a folder (its writers' lock, held until the job
    // ends): two would replace each other's frames.csv between their OBJs.
    ok = ok && lock->Acquire(options.output_dir, error, "the sequence folder " +
                                                            options.output_dir);
    // What a run killed while writing left (util/atomic_file.h).
    std::set<std::string> outputs = {"frames.csv", "latents.bin", "targets.txt", "key.txt"};
    for (const SequenceFrame& f : frames) outputs.insert(f.name + ".obj");
    std::vector<std::string> removed;
    // (Only by the lock's first holder: another PathLock of this process could be writing.)
    ok = ok && (!lock->first() ||
                RemoveStaleTemporaryFiles(
                    options.output_dir,
                    [&](const std::string& name) { return outputs.count(name) > 0; }, &removed,
                    error));
    for (const std::string& line : removed) *note += "cleanup: " + line + "\n";
    const std::string key_path = options.output_dir + "/key.txt";
    const std::string key = SequenceKey(options, model, frames);
    if (ok && MayExist(key_path) && MayExist(options.output_dir + "/frames.csv") &&
        !SameSequenceKey(ReadWholeFile(key_path), key)) {
      *error = options.output_dir + ": its frames were fitted with another model or other fit "
               "options (key.txt); remove the folder, or write to another --output_dir";
      ok = false;
    }
    const std::string csv_path = options.output_dir + "/frames.csv";
    ok = ok && ReadFramesDone(csv_path, options.output_dir, model, frames, done, error);
    const std::string targets_path = options.output_dir + "/targets.txt";
    const std::string targets = SequenceTargetsText(frames);
    if (ok && !done->empty() && MayExist(targets_path)) {
      const int same = FramesOfSameTargets(ReadWholeFile(targets_path), targets,
                                           static_cast<int>(done->size()));
      if (same < static_cast<int>(done->size())) {
        *note += "frame " + std::to_string(same) + " (" + frames[same].name + "): its target " +
                "differs from the one it was fitted to (targets.txt); it and the frames after "
                "it are fitted again\n";
        done->resize(same);
      }
    }
    // frames.csv keeps the rows of the frames done alone (not those after a frame whose
    // OBJ is missing, nor those whose target changed) before targets.txt records the
    // targets of all frames, so that a run killed in between does not take them for
    // fits of these targets. latents.bin keeps their latents alone, and the OBJs of the
    // frames not done go (a run killed between a round's OBJs and its rows, or fitted
    // to targets that changed): only the frames done have results in the folder.
    if (ok && MayExist(csv_path)) {
      std::string csv = SequenceCsvHeader(model) + "\n";
      for (const DoneFrame& d : *done) csv += d.line + "\n";
      if (ReadWholeFile(csv_path) != csv) ok = WriteFileAtomically(csv_path, csv, error);
    }
    const std::string latents_path = options.output_dir + "/latents.bin";
    if (ok && MayExist(latents_path)) {
      Eigen::MatrixXd track(model.latent_dim(), done->size());
      for (size_t f = 0; f < done->size(); ++f) track.col(f) = (*done)[f].latent;
      ok = WriteMatrixFile(latents_path, track, error);
    }
    for (size_t f = done->size(); f < frames.size() && ok; ++f) {
      std::error_code code;
      fs::remove(options.output_dir + "/" + frames[f].name + ".obj", code);
    }
    ok = ok && WriteFileAtomically(key_path, key, error);
    ok = ok && WriteFileAtomically(targets_path, targets, error);
  }
  return ranks.Agree(ok, error);
}

// The first line of the log: the sequence, its frames' kind and count, where they go,
// how they are shared and their landmarks.
void LogSequenceStart(const FitSequenceOptions& options, const std::vector<SequenceFrame>& frames,
                      const SequenceRanks& ranks, std::ostream& log) {
  log << "sequence " << options.sequence << ": " << frames.size() << " " << frames.front().kind
      << " frames -> " << options.output_dir;
  if (!options.warm_start) {
    log << "; independent frames";
    if (ranks.distributed) {
      log << ", shared among " << ranks.size << " ranks (" << ranks.comm->Description() << ")";
    }
  }
  if (!options.landmarks.empty()) {
    log << "; with landmarks from " << options.landmarks << " (weight "
        << FormatDouble(options.points.landmark_weight) << ")";
  }
  log << "\n";
}

// Fits a sequence's frames one at a time. With warm starts one fitter serves the whole
// sequence and each frame after the first starts from the previous one's latent, bones
// and equilibrium; without, every frame gets a fitter of its own and the start
// FitStartOptions chooses for it.
class SequenceFrameFitter {
 public:
  SequenceFrameFitter(const FitSequenceOptions& options, const ActiveModel& model,
                      const std::vector<SequenceFrame>& frames)
      : options_(options), model_(model), frames_(frames) {
    if (options.warm_start) {
      warm_ = std::make_unique<LatentFitter>(model, options.fit);
      z_ = options.start.mean_latent ? warm_->MeanLatent() : warm_->PriorLatent();
    }
  }

  // Nonzeros of the stiffness factor (for the BLAS threads, util/blas.h).
  double FactorNonzeros() const {
    return warm_ ? warm_->FactorNonzeros() : LatentFitter(model_, options_.fit).FactorNonzeros();
  }

  // With warm starts: continues after the last frame done, `last` (its latent and bones,
  // its equilibrium simulated again if frames remain: `more`). False with *error if it
  // cannot be simulated.
  bool ContinueAfter(const DoneFrame& last, bool more, std::string* error) {
    if (!warm_) return true;
    z_ = last.latent;
    warm_->set_bone_transforms(last.bones);
    warm_->SetTemporalPrior(options_.temporal_prior, last.latent, last.bones);
    Eigen::Matrix3Xd state, surface;
    return !more || warm_->Simulate(z_, &state, &surface, error);
  }

  // Fits frame f into *block (FrameBlockSize numbers, jobs/sequence_outputs.h); false with
  // *status and *message (naming the frame's file) if it cannot be fitted.
  bool Fit(int f, std::vector<double>* block, JobStatus* status, std::string* message) {
    const SequenceFrame& frame = frames_[f];
    WallTimer frame_timer;
    const bool is_cloud = frame.kind == "points";
    std::unique_ptr<LatentFitter> own;
    LatentFitter* fitter = warm_.get();
    Eigen::VectorXd z = z_;
    if (!warm_) {
      own = std::make_unique<LatentFitter>(model_, options_.fit);
      fitter = own.get();
      z = options_.start.mean_latent ? fitter->MeanLatent() : fitter->PriorLatent();
    }
    std::string start = "previous";
    std::string fit_error;
    LatentFitResult fit;
    bool fitted = false;
    PointCloudFitOptions cloud_options = options_.points;
    cloud_options.landmarks = frame.landmarks;
    if (!warm_ || f == 0) {  // from the start chosen for this frame
      fitted = FitFromChosenStart(fitter, is_cloud ? nullptr : &frame.target,
                                  is_cloud ? &frame.cloud : nullptr, cloud_options,
                                  options_.start, z, &fit, &fit_error);
      if (fit.start.empty()) {  // no start could be simulated, or none reaches a scan
        return Failed(frame, fit, "", frame_timer.Seconds(), fit_error, block, status, message);
      }
      start = fit.start;
    } else {
      fitted = is_cloud ? fitter->FitPointCloud(frame.cloud, cloud_options, z, &fit, &fit_error)
                        : fitter->Fit(frame.target, z, &fit, &fit_error);
    }
    // A fit whose minimizer failed (its Jacobian could not be evaluated at a point it
    // accepted) is no result either, as for a single target (RunFitJob).
    if (fitted && fit.failed) fit_error = "the fit failed: " + fit.message;
    if (!fitted || fit.failed) {
      return Failed(frame, fit, start, frame_timer.Seconds(), fit_error, block, status, message);
    }
    if (warm_) {
      z_ = fit.latent;
      warm_->SetTemporalPrior(options_.temporal_prior, fit.latent, fit.bones);
    }
    PackFrameBlock(model_, fit, start, frame_timer.Seconds(), block);
    return true;
  }

 private:
  // A frame that cannot be fitted: with warm starts the sequence stops there (false, with
  // *status and *message); independent frames go on: *block says it failed
  // (PackFailedFrameBlock), *message why, and the frame counts as fitted (true).
  bool Failed(const SequenceFrame& frame, const LatentFitResult& fit, const std::string& start,
              double seconds, const std::string& fit_error, std::vector<double>* block,
              JobStatus* status, std::string* message) {
    *message = frame.path + ": " + fit_error;
    if (warm_) {
      *status = JobStatus::kNotConverged;
      *message += " (frames before it are written; rerun to retry)";
      return false;
    }
    PackFailedFrameBlock(model_, fit, start, seconds, block);
    return true;
  }

  const FitSequenceOptions& options_;
  const ActiveModel& model_;
  const std::vector<SequenceFrame>& frames_;
  std::unique_ptr<LatentFitter> warm_;  // with warm starts
  Eigen::VectorXd z_;                   // with warm starts: the latent to continue from
};

// One round's fitted frames [begin, end) on rank 0 (*blocks, FrameBlockSize numbers per
// frame, in order) and the first frame that stopped the sequence (n, the sequence's
// length, if none) on every rank. This rank fits frame begin + rank (if < end); when that
// stops the sequence, *status and *message are that rank's (the caller shares the first
// failing frame's). Independent frames that could not be fitted do not stop it:
// *failures (every rank, one per frame of the round) holds why ("" for those fitted).
int FitRound(SequenceFrameFitter* fitter, const SequenceRanks& ranks, int begin, int end, int n,
             int block_size, std::vector<double>* blocks, JobStatus* status,
             std::string* message, std::vector<std::string>* failures) {
  const int mine = begin + ranks.rank;  // this rank's frame, if < end
  std::vector<double> block;
  const bool fitted = mine >= end || fitter->Fit(mine, &block, status, message);
  if (!fitted) block.assign(block_size, 0.0);  // sent, not written
  const bool failed_here = fitted && mine < end && BlockFailed(block.data());
  int first_failure = fitted ? n : mine;
  failures->assign(end - begin, "");
  if (!ranks.distributed) {
    *blocks = block;
    if (failed_here) (*failures)[0] = *message;
    return first_failure;
  }
  ranks.comm->MinToAll(&first_failure, 1);
  std::vector<int> fine(ranks.size, 1);  // 0 where a rank's frame could not be fitted
  fine[ranks.rank] = failed_here ? 0 : 1;
  ranks.comm->MinToAll(fine.data(), ranks.size);
  for (int k = 0; k < end - begin; ++k) {
    if (fine[k] != 0) continue;
    std::string why = k == ranks.rank ? *message : std::string();
    ranks.comm->BroadcastText(&why, k);
    (*failures)[k] = why;
  }
  std::vector<int> counts(ranks.size, 0);
  for (int k = 0; k < end - begin; ++k) counts[k] = block_size;
  if (ranks.root) blocks->resize(static_cast<size_t>(block_size) * (end - begin));
  ranks.comm->GatherToRoot(block.data(), counts, blocks->data());
  return first_failure;
}

// Rank 0 writes frames [begin, written) of a round from their blocks: the OBJs, the
// latents into *track and latents.bin (its first `written` columns), then their rows
// appended to *csv and frames.csv (a frame is done once its row is there).
bool WriteRound(const FitSequenceOptions& options, const ActiveModel& model,
                const std::vector<SequenceFrame>& frames, const std::vector<double>& blocks,
                int begin, int written, Eigen::MatrixXd* track, std::string* csv,
                std::string* error) {
  const int block_size = FrameBlockSize(model.latent_dim(), static_cast<int>(model.bones.size()),
                                        model.num_surface_vertices());
  bool ok = true;
  for (int f = begin; f < written && ok; ++f) {
    const double* b = blocks.data() + static_cast<size_t>(block_size) * (f - begin);
    const std::string obj = options.output_dir + "/" + frames[f].name + ".obj";
    if (!BlockFailed(b)) {
      SurfaceMesh surface = model.neutral;
      surface.vertices = BlockSurface(model, b);
      ok = WriteObj(obj, surface, error);
    } else {  // a frame that could not be fitted has no OBJ, not an earlier run's either
      std::error_code code;
      fs::remove(obj, code);
    }
    track->col(f) = BlockLatent(model, b);
    *csv += FrameCsvRow(model, f, frames[f], b) + "\n";
  }
  ok = ok && WriteMatrixFile(options.output_dir + "/latents.bin", track->leftCols(written), error);
  return ok && WriteFileAtomically(options.output_dir + "/frames.csv", *csv, error);
}

// The progress line of frame f (of n; block `b`), with frames per second and an ETA
// from `fitted` frames in `elapsed` seconds; with ranks, the rank that fitted it.
// A frame that could not be fitted logs why (`failure`) instead of its errors.
void LogFrame(const std::vector<SequenceFrame>& frames, int f, const double* b, int fitted,
              double elapsed, const SequenceRanks& ranks, int rank_of_frame,
              const std::string& failure, std::ostream& log) {
  const int n = static_cast<int>(frames.size());
  const double fps = fitted / std::max(elapsed, 1e-9);
  log << "frame " << f + 1 << "/" << n << " " << frames[f].name;
  if (BlockFailed(b)) {
    log << ": could not be fitted (" << failure << "), " << std::setprecision(3) << b[6] << " s";
  } else {
    log << ": error mean " << std::setprecision(4) << b[2] << " over " << static_cast<int>(b[0])
        << " points, " << static_cast<int>(b[5]) << " it, " << std::setprecision(3) << b[6]
        << " s";
  }
  if (ranks.distributed) log << " (rank " << rank_of_frame << ")";
  log << "; " << std::setprecision(3) << fps << " frames/s, ETA "
      << FormatSeconds((n - f - 1) / fps) << std::endl;
}

}  // namespace

FitSequenceResult RunFitSequence(const FitSequenceOptions& options, const ActiveModel& model,
                                 std::ostream& job_log) {
  FitSequenceResult result;
  auto fail = [&](JobStatus status, const std::string& message) {
    result.status = status;
    result.message = message;
    return result;
  };
  const SequenceRanks ranks(options.communicator);
  std::ostringstream quiet;  // the other ranks' log
  std::ostream& log = ranks.root ? job_log : quiet;
  std::string error;
  // Bad input every rank sees alike (same options): no collective needed.
  if (!options.Validate(&error) || !CheckSharing(options, &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  if (options.output_dir.empty()) return fail(JobStatus::kBadInput, "--output_dir is required");
  // Paths may resolve differently on another machine: the ranks agree.
  if (!ranks.Agree(CheckOutputApart(options.output_dir, options.model, &error), &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  if (!model.decoder) return fail(JobStatus::kBadInput, options.model + ": the model is not trained");
  if (!CheckPointCloudScales(options.points, ModelSize(model.neutral.vertices), &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  std::vector<SequenceFrame> frames;
  if (!ReadFramesOnEveryRank(options, model, ranks, &frames, &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  bool apart = true;
  for (const SequenceFrame& f : frames) {
    // Frame OBJs go to output_dir/<name>.obj: not into the targets' own folder (over a
    // target, or as new targets of the sequence on a rerun).
    std::error_code code;
    const fs::path folder = fs::path(f.path).parent_path();
    if (apart &&
        fs::equivalent(options.output_dir, folder.empty() ? fs::path(".") : folder, code)) {
      error = options.output_dir + ": is the folder of the frame " + f.path +
              "; write the outputs elsewhere";
      apart = false;
    }
    result.frame_names.push_back(f.name);
  }
  if (!ranks.Agree(apart, &error)) return fail(JobStatus::kBadInput, error);
  std::vector<DoneFrame> done;
  PathLock output_lock;  // rank 0's, until the job ends
  std::string targets_note;
  if (!OpenOutputFolder(options, model, frames, ranks, &output_lock, &done, &targets_note,
                        &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  if (options.warm_start) {
    // Frames an independent run could not fit: fitted again, and every frame after them
    // (each continues from the one before). Their rows stay in frames.csv until this
    // run writes frames of its own: a warm run that fails there loses no frame.
    done.erase(std::find_if(done.begin(), done.end(), [](const DoneFrame& d) { return d.failed; }),
               done.end());
  }
  int failed_before = static_cast<int>(
      std::count_if(done.begin(), done.end(), [](const DoneFrame& d) { return d.failed; }));
  if (ranks.distributed) ranks.comm->Broadcast(&failed_before, 1, 0);
  std::string first_failure_message;
  const int n = static_cast<int>(frames.size());
  LogSequenceStart(options, frames, ranks, log);
  log << targets_note;

  std::string csv = SequenceCsvHeader(model) + "\n";
  Eigen::MatrixXd track(model.latent_dim(), n);
  for (size_t f = 0; f < done.size(); ++f) {
    csv += done[f].line + "\n";
    track.col(f) = done[f].latent;
  }
  int first = static_cast<int>(done.size());
  if (ranks.distributed) ranks.comm->Broadcast(&first, 1, 0);
  result.frames_resumed = first;
  SequenceFrameFitter fitter(options, model, frames);
  const ScopedBlasThreads blas(BlasThreadsForFactor(fitter.FactorNonzeros(), BlasThreads()));
  if (options.warm_start && !done.empty() && first < n) {
    // The row a warm start continues from drives the next solve: its numbers were read as
    // finite, but a damaged row (a latent of 1e6) ran for minutes to a solve that failed.
    const std::string row =
        options.output_dir + "/frames.csv:" + std::to_string(done.back().line_number);
    if (!CheckLatentActuations(model, done.back().latent, row, &error) ||
        !CheckBoneMotions(model, done.back().bones, row, &error)) {
      return fail(JobStatus::kBadInput, error + " (the file is damaged: remove the folder or "
                                                "choose another --output_dir)");
    }
  }
  if (first > 0) {
    log << "resuming at frame " << first << " (" << frames[first < n ? first : n - 1].name
        << "): " << first << " frames done\n";
    if (!done.empty() && !fitter.ContinueAfter(done.back(), first < n, &error)) {
      return fail(JobStatus::kNotConverged, "the last frame done, " + frames[first - 1].name +
                                                ", cannot be simulated again: " + error);
    }
  }

  const int block_size = FrameBlockSize(model.latent_dim(), static_cast<int>(model.bones.size()),
                                        model.num_surface_vertices());
  WallTimer timer;
  for (int begin = first; begin < n; begin += ranks.size) {
    const int end = std::min(n, begin + ranks.size);  // this round: frames [begin, end)
    std::vector<double> blocks;
    JobStatus status = JobStatus::kOk;
    std::string message;
    std::vector<std::string> failures;
    const int first_failure = FitRound(&fitter, ranks, begin, end, n, block_size, &blocks,
                                       &status, &message, &failures);
    // Rank 0 writes the round's frames before the first failing one.
    const int written = std::min(end, first_failure);
    bool ok = !ranks.root || written <= begin ||
              WriteRound(options, model, frames, blocks, begin, written, &track, &csv, &error);
    if (!ranks.Agree(ok, &error)) return fail(JobStatus::kBadInput, error);
    for (int f = begin; f < written; ++f) {
      ++result.frames_fitted;
      const std::string& failure = failures[f - begin];
      if (!failure.empty()) {
        ++result.frames_failed;
        if (first_failure_message.empty()) first_failure_message = failure;
      }
      if (!ranks.root) continue;
      const double* b = blocks.data() + static_cast<size_t>(block_size) * (f - begin);
      LogFrame(frames, f, b, result.frames_fitted, timer.Seconds(), ranks, f - begin, failure,
               log);
    }
    if (first_failure < n) {
      int code = static_cast<int>(status);
      if (ranks.distributed) {
        ranks.comm->BroadcastText(&message, first_failure - begin);
        ranks.comm->Broadcast(&code, 1, first_failure - begin);
      }
      return fail(static_cast<JobStatus>(code), message);
    }
  }
  result.seconds = timer.Seconds();
  result.frames_per_second = result.frames_fitted / std::max(result.seconds, 1e-9);
  if (first == n) {
    log << "all " << n << " frames were done already\n";
    const bool ok =
        !ranks.root || WriteMatrixFile(options.output_dir + "/latents.bin", track, &error);
    if (!ranks.Agree(ok, &error)) return fail(JobStatus::kBadInput, error);
  }
  log << "fitted " << result.frames_fitted << " frames in " << std::setprecision(4)
      << result.seconds << " s (" << result.frames_per_second << " frames/s); wrote "
      << options.output_dir << "/frames.csv, latents.bin and one OBJ per frame\n";
  const int failed = failed_before + result.frames_failed;
  if (failed > 0) {
    return fail(JobStatus::kNotConverged,
                std::to_string(failed) + " of " + std::to_string(n) +
                    " frames could not be fitted (" +
                    (first_failure_message.empty() ? std::string("in an earlier run")
                                                   : "the first in this run: " +
                                                         first_failure_message) +
                    "); frames.csv says converged -1 for them, and they have no OBJ; the "
                    "other frames are written");
  }
  return result;
}

bool FitSequenceOptions::Validate(std::string* error) const {
  if (!ValidateFitTargetOptions(target_kind, fit, points, error)) return false;
  return OptionChecks()
      .Require(max_frames != 0, "max_frames must be >= 1, or < 0 for all frames")
      .NonNegative("temporal_prior", temporal_prior)
      .Require(temporal_prior <= 0 || warm_start,
               "temporal_prior pulls a frame toward the previous one: it needs warm-started "
               "frames (--sequence_warm_start)")
      .Done(error);
}

FitSequenceResult RunFitSequenceJob(const FitSequenceOptions& options, std::ostream& log) {
  FitSequenceResult result;
  auto fail = [&](const std::string& message) {
    result.status = JobStatus::kBadInput;
    result.message = message;
    return result;
  };
  {
    std::string invalid;
    if (!options.Validate(&invalid)) return fail(invalid);
  }
  if (options.model.empty() || options.sequence.empty() || options.output_dir.empty()) {
    return fail("--model, --sequence and --output_dir are required");
  }
  std::string error;
  if (!CheckSharing(options, &error)) return fail(error);
  ActiveModel model;
  bool ok = LoadModel(options.model, &model, &error);
  if (ok && !model.decoder) {
    error = options.model + ": the model is not trained";
    ok = false;
  }
  const Communicator* comm = options.communicator;
  if (comm != nullptr && comm->size() > 1) {
    ok = ShareModel(*comm, options.model, ok, &model, &error);
  }
  if (!ok) return fail(error);
  return RunFitSequence(options, model, log);
}

}  // namespace aqs
