#include "jobs/fit_sequence.h"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <memory>
#include <sstream>

#include <Eigen/Geometry>
#include <glog/logging.h>

#include "dist/model_sharing.h"
#include "fit/chosen_start_fit.h"
#include "jobs/fit_job.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/file_extension.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/number_format.h"
#include "util/wall_timer.h"
#include "util/option_checks.h"
#include "util/text_split.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// The frame files of a sequence specification, with where each was listed.
bool ResolveFrames(const std::string& spec, std::vector<std::pair<std::string, std::string>>* out,
                   std::string* error) {
  std::error_code code;
  std::vector<std::string> found;
  if (spec.empty()) {
    *error = "no sequence given";
    return false;
  }
  if (fs::is_directory(spec, code)) {
    for (const auto& entry : fs::directory_iterator(spec, code)) {
      const std::string ext = LowercaseExtension(entry.path().string());
      if (entry.is_regular_file() && (ext == ".obj" || ext == ".txt" || ext == ".ply")) {
        found.push_back(entry.path().string());
      }
    }
    std::sort(found.begin(), found.end());
    for (const std::string& f : found) out->emplace_back(f, f);
  } else if (spec.find_first_of("*?[") != std::string::npos) {
    glob_t matches;
    if (glob(spec.c_str(), 0, nullptr, &matches) == 0) {
      for (size_t i = 0; i < matches.gl_pathc; ++i) found.push_back(matches.gl_pathv[i]);
    }
    globfree(&matches);
    std::sort(found.begin(), found.end());
    for (const std::string& f : found) out->emplace_back(f, f);
  } else if (LowercaseExtension(spec) == ".txt" && spec.find(',') == std::string::npos) {
    LineReader reader(spec);
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    const fs::path base = fs::path(spec).parent_path();
    std::vector<std::string> tokens;
    while (reader.NextTokens(&tokens)) {
      if (tokens.size() != 1) {
        *error = reader.Where("expected one target file per line (a sequence list)");
        return false;
      }
      const fs::path p(tokens[0]);
      const std::string resolved = p.is_absolute() ? p.string() : (base / p).string();
      if (!fs::exists(resolved)) {
        *error = reader.Where("target file '" + resolved + "' does not exist");
        return false;
      }
      out->emplace_back(resolved, spec + ":" + std::to_string(reader.line_number()));
    }
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
  } else {
    for (const std::string& item : SplitList(spec)) {
      if (!fs::exists(item)) {
        *error = "target file '" + item + "' does not exist";
        return false;
      }
      out->emplace_back(item, item);
    }
  }
  if (out->empty()) {
    *error = "the sequence '" + spec + "' matches no target files (.obj, .txt, .ply)";
    return false;
  }
  return true;
}

// Prefixes an error about a listed file with where it was listed.
std::string From(const SequenceFrame& f, const std::string& message) {
  return f.origin == f.path ? message : f.origin + ": " + message;
}

std::string CsvHeader(const ActiveModel& model) {
  std::string h = "frame,name,kind,points,used_points,matched_fraction,mean_error,rms_error,"
                  "max_error,iterations,seconds,converged,start,factorizations";
  for (int i = 0; i < model.latent_dim(); ++i) h += ",z" + std::to_string(i + 1);
  for (const Bone& b : model.bones) {
    for (const char* p : {"rx", "ry", "rz", "tx", "ty", "tz"}) h += "," + b.name + "_" + p;
  }
  return h;
}

// A CSV number (read back bit for bit, util/number_format.h).
void Append(double v, std::string* out) {
  *out += ',';
  AppendDouble(v, out);
}

struct DoneRow {
  std::string line;
  Eigen::VectorXd latent;
  std::vector<RigidTransform> bones;
};

// Reads the frames already done from output_dir/frames.csv: rows in order whose name
// matches the frame and whose OBJ exists. A header for another model, or rows of
// other frames, are errors (the folder holds another run).
bool ReadDone(const std::string& csv, const std::string& output_dir, const ActiveModel& model,
              const std::vector<SequenceFrame>& frames, std::vector<DoneRow>* done,
              std::string* error) {
  if (!fs::exists(csv)) return true;
  LineReader reader(csv);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  const std::string header = CsvHeader(model);
  const int d = model.latent_dim();
  const size_t columns = 14 + d + 6 * model.bones.size();
  while (reader.NextLine()) {
    if (reader.line_number() == 1) {
      if (reader.line() != header) {
        *error = reader.Where("written for another model (the header differs): remove the "
                              "folder or choose another --output_dir");
        return false;
      }
      continue;
    }
    const std::vector<std::string> cells = SplitFields(reader.line());
    const size_t f = done->size();
    int index = -1;
    if (cells.size() != columns || !ParseInt(cells[0], &index) || index != static_cast<int>(f)) {
      *error = reader.Where("expected the row of frame " + std::to_string(f) + " (" +
                            std::to_string(columns) + " columns)");
      return false;
    }
    if (f >= frames.size() || cells[1] != frames[f].name) {
      *error = reader.Where("frame " + std::to_string(f) + " is '" + cells[1] +
                            "', but this sequence's is '" +
                            (f < frames.size() ? frames[f].name : std::string("(none)")) +
                            "': the folder holds another run; remove it or choose another "
                            "--output_dir");
      return false;
    }
    if (!fs::exists(output_dir + "/" + frames[f].name + ".obj")) break;  // redo from here
    DoneRow row;
    row.line = reader.line();
    row.latent.resize(d);
    bool ok = true;
    for (int i = 0; i < d && ok; ++i) ok = ParseDouble(cells[14 + i], &row.latent[i]);
    for (size_t b = 0; b < model.bones.size() && ok; ++b) {
      double p[6];
      for (int k = 0; k < 6 && ok; ++k) ok = ParseDouble(cells[14 + d + 6 * b + k], &p[k]);
      if (ok) row.bones.push_back(BoneTransformFromParameters(p));
    }
    if (!ok) {
      *error = reader.Where("a latent or bone number is not a number");
      return false;
    }
    done->push_back(row);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  return true;
}

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

// A fitted frame as rank 0 writes it, in doubles (sent between ranks): kFrameScalars
// numbers (used points, matched fraction, mean, rms and max error, iterations,
// seconds, converged, start, factorizations), the latent (d), the bones' motion
// parameters (6 per bone), the surface (3 x ns, column-major). The start is -2 for
// "previous", -1 for "given", else the training pose's index.
constexpr int kFrameScalars = 10;

int FrameBlockSize(int d, int nb, int ns) { return kFrameScalars + d + 6 * nb + 3 * ns; }

void PackFrame(const ActiveModel& model, const LatentFitResult& fit, const std::string& start,
               double seconds, std::vector<double>* block) {
  int start_index = -3;
  if (start == "previous") {
    start_index = -2;
  } else if (start == "given") {
    start_index = -1;
  } else {
    for (int p = 0; p < model.num_poses() && start_index == -3; ++p) {
      if (model.poses[p].name == start) start_index = p;
    }
  }
  CHECK_NE(start_index, -3) << "unknown start " << start;
  *block = {double(fit.used_points), fit.matched_fraction, fit.mean_error, fit.rms_error,
            fit.max_error, double(fit.iterations), seconds, fit.converged ? 1.0 : 0.0,
            double(start_index), double(fit.solve_factorizations + fit.jacobians)};
  block->insert(block->end(), fit.latent.data(), fit.latent.data() + fit.latent.size());
  for (const RigidTransform& t : fit.bones) {
    double p[6];
    BoneTransformToParameters(t, p);
    block->insert(block->end(), p, p + 6);
  }
  block->insert(block->end(), fit.surface.data(), fit.surface.data() + fit.surface.size());
  CHECK_EQ(static_cast<int>(block->size()),
           FrameBlockSize(model.latent_dim(), static_cast<int>(model.bones.size()),
                          model.num_surface_vertices()));
}

// Frame f's row of frames.csv from its block.
std::string FrameRow(const ActiveModel& model, int f, const SequenceFrame& frame,
                     const double* b) {
  const bool is_cloud = frame.kind == "points";
  const int start = static_cast<int>(b[8]);
  std::string row = std::to_string(f) + "," + frame.name + "," + frame.kind + "," +
                    std::to_string(is_cloud ? frame.cloud.cols() : frame.target.num_points()) +
                    "," + std::to_string(static_cast<int>(b[0]));
  for (int k = 1; k <= 4; ++k) Append(b[k], &row);
  row += "," + std::to_string(static_cast<int>(b[5]));
  Append(b[6], &row);
  row += std::string(",") + (b[7] != 0.0 ? "1" : "0") + "," +
         (start == -2 ? std::string("previous")
                      : start == -1 ? std::string("given") : model.poses[start].name) +
         "," + std::to_string(static_cast<int>(b[9]));
  const int values = model.latent_dim() + 6 * static_cast<int>(model.bones.size());
  for (int i = 0; i < values; ++i) Append(b[kFrameScalars + i], &row);
  return row;
}

}  // namespace

bool ReadSequenceFrames(const FitSequenceOptions& options, int ns,
                        std::vector<SequenceFrame>* frames, std::string* error) {
  std::vector<std::pair<std::string, std::string>> files;
  if (!ResolveFrames(options.sequence, &files, error)) return false;
  if (options.max_frames >= 0 && static_cast<int>(files.size()) > options.max_frames) {
    files.resize(options.max_frames);
  }
  const std::string& forced = options.target_kind;
  if (forced != "auto" && forced != "pose" && forced != "markers" && forced != "points") {
    *error = "--target_kind must be auto, pose, markers or points, got '" + forced + "'";
    return false;
  }
  std::map<std::string, std::string> names;
  frames->clear();
  for (const auto& [path, origin] : files) {
    SequenceFrame f;
    f.path = path;
    f.origin = origin;
    f.name = fs::path(path).stem().string();
    const auto [it, inserted] = names.emplace(f.name, path);
    if (!inserted) {
      *error = From(f, path + ": frame name '" + f.name + "' is already taken by " + it->second +
                           " (frames are named by file name)");
      return false;
    }
    const std::string ext = LowercaseExtension(path);
    SurfaceMesh surface;
    f.kind = forced;
    if (f.kind == "auto") {
      if (ext == ".txt") {
        f.kind = "markers";
      } else if (ext == ".ply") {
        f.kind = "points";
      } else if (ext == ".obj") {
        if (!ReadObj(path, &surface, error)) {
          *error = From(f, *error);
          return false;
        }
        // The first frame decides; a later OBJ of another vertex count is a mismatch.
        const bool pose_sequence = frames->empty() ? surface.num_vertices() == ns
                                                   : frames->front().kind == "pose";
        f.kind = pose_sequence ? "pose" : "points";
      } else {
        *error = From(f, path + ": cannot tell the target kind from the extension (.obj, .txt "
                             "or .ply); give --target_kind");
        return false;
      }
    }
    if (!frames->empty() && f.kind != frames->front().kind) {
      *error = From(f, path + ": a " + f.kind + " target, but the sequence's first frame " +
                           frames->front().path + " is a " + frames->front().kind +
                           " target (a sequence has one kind)");
      return false;
    }
    if (f.kind == "pose") {
      if (surface.num_vertices() == 0 && !ReadObj(path, &surface, error)) {
        *error = From(f, *error);
        return false;
      }
      if (surface.num_vertices() != ns) {
        *error = From(f, path + ": " + std::to_string(surface.num_vertices()) +
                             " vertices, but the model's surface" +
                             (frames->empty() ? std::string("") : " (and the first frame's)") +
                             " has " + std::to_string(ns));
        return false;
      }
      f.target = FullSurfaceTarget(surface.vertices);
    } else if (f.kind == "markers") {
      std::vector<int> vertices;
      Eigen::Matrix3Xd positions;
      if (!ReadMarkers(path, ns, &vertices, &positions, error)) {
        *error = From(f, *error);
        return false;
      }
      f.target = VertexTarget(vertices, positions);
    } else {
      if (!ReadPointCloud(path, &f.cloud, error)) {
        *error = From(f, *error);
        return false;
      }
      if (f.cloud.cols() < 3) {
        *error = From(f, path + ": fewer than 3 points");
        return false;
      }
    }
    frames->push_back(std::move(f));
  }
  if (options.landmarks.empty()) return true;
  // One landmarks file per frame, in the frames' order.
  if (frames->front().kind != "points") {
    *error = options.landmarks + ": landmarks go with a sequence of point clouds (scans), but " +
             options.sequence + " is a sequence of " + frames->front().kind + " targets";
    return false;
  }
  std::vector<std::pair<std::string, std::string>> landmark_files;
  if (!ResolveFrames(options.landmarks, &landmark_files, error)) return false;
  if (options.max_frames >= 0 && static_cast<int>(landmark_files.size()) > options.max_frames) {
    landmark_files.resize(options.max_frames);
  }
  if (landmark_files.size() != frames->size()) {
    *error = options.landmarks + ": " + std::to_string(landmark_files.size()) +
             " landmark files for the " + std::to_string(frames->size()) + " frames of " +
             options.sequence + " (one per frame, in the frames' order)";
    return false;
  }
  for (size_t k = 0; k < frames->size(); ++k) {
    const auto& [path, origin] = landmark_files[k];
    if (!ReadMarkerTarget(path, ns, &(*frames)[k].landmarks, error)) {
      if (origin != path) *error = origin + ": " + *error;
      return false;
    }
  }
  return true;
}

FitSequenceResult RunFitSequence(const FitSequenceOptions& options, const ActiveModel& model,
                                 std::ostream& job_log) {
  FitSequenceResult result;
  auto fail = [&](JobStatus status, const std::string& message) {
    result.status = status;
    result.message = message;
    return result;
  };
  const Communicator* comm = options.communicator;
  const bool distributed = comm != nullptr && comm->size() > 1;
  const bool root = !distributed || comm->is_root();
  const int rank = distributed ? comm->rank() : 0;
  const int size = distributed ? comm->size() : 1;
  std::ostringstream quiet;  // the other ranks' log
  std::ostream& log = root ? job_log : quiet;
  std::string error;
  // Bad input every rank sees alike (same options): no collective needed.
  if (!CheckSharing(options, &error)) return fail(JobStatus::kBadInput, error);
  if (options.output_dir.empty()) return fail(JobStatus::kBadInput, "--output_dir is required");
  if (!model.decoder) return fail(JobStatus::kBadInput, options.model + ": the model is not trained");
  std::vector<SequenceFrame> frames;
  bool ok = ReadSequenceFrames(options, model.num_surface_vertices(), &frames, &error);
  if (distributed) {
    // Every rank reads the targets (the same path on every machine); they must be rank
    // 0's frames.
    std::string names;
    for (const SequenceFrame& f : frames) names += f.name + "\n";
    std::string root_names = names;
    comm->BroadcastText(&root_names, 0);
    if (ok && names != root_names) {
      error = options.sequence + ": " + std::to_string(frames.size()) +
              " frames here, which differ from rank 0's (another sequence at that path?)";
      ok = false;
    }
    ok = comm->Agree(ok, &error);
  }
  if (!ok) return fail(JobStatus::kBadInput, error);
  for (const SequenceFrame& f : frames) result.frame_names.push_back(f.name);
  const std::string csv_path = options.output_dir + "/frames.csv";
  std::vector<DoneRow> done;
  if (root) {
    std::error_code code;
    fs::create_directories(options.output_dir, code);
    if (code) {
      error = options.output_dir + ": cannot create the folder (" + code.message() + ")";
      ok = false;
    }
    ok = ok && ReadDone(csv_path, options.output_dir, model, frames, &done, &error);
  }
  if (distributed) ok = comm->Agree(ok, &error);
  if (!ok) return fail(JobStatus::kBadInput, error);
  const int n = static_cast<int>(frames.size());
  const int d = model.latent_dim();
  const int nb = static_cast<int>(model.bones.size());
  const int ns = model.num_surface_vertices();
  log << "sequence " << options.sequence << ": " << n << " " << frames.front().kind
      << " frames -> " << options.output_dir
      << (options.warm_start ? std::string("")
                             : distributed ? "; independent frames, shared among " +
                                                 std::to_string(size) + " ranks (" +
                                                 comm->Description() + ")"
                                           : "; independent frames")
      << (options.landmarks.empty() ? std::string("")
                                    : "; with landmarks from " + options.landmarks + " (weight " +
                                          FormatDouble(options.points.landmark_weight) + ")")
      << "\n";

  std::string csv = CsvHeader(model) + "\n";
  Eigen::MatrixXd track(d, n);
  for (size_t f = 0; f < done.size(); ++f) {
    csv += done[f].line + "\n";
    track.col(f) = done[f].latent;
  }
  int first = static_cast<int>(done.size());
  if (distributed) comm->Broadcast(&first, 1, 0);
  result.frames_resumed = first;
  // Warm starts: one fitter for the whole sequence, and the latent it continues from.
  std::unique_ptr<LatentFitter> warm;
  Eigen::VectorXd z;
  if (options.warm_start) {
    warm = std::make_unique<LatentFitter>(model, options.fit);
    z = options.start.mean_latent ? warm->MeanLatent() : warm->PriorLatent();
  }
  // BLAS threads for this model's factor size (util/blas.h).
  const ScopedBlasThreads blas(BlasThreadsForFactor(
      warm ? warm->FactorNonzeros() : LatentFitter(model, options.fit).FactorNonzeros(),
      BlasThreads()));
  if (first > 0) {
    log << "resuming at frame " << first << " (" << frames[first < n ? first : n - 1].name
        << "): " << first << " frames done\n";
    if (warm) {
      // Warm start from the last frame done: its latent and bones, its equilibrium
      // simulated again.
      z = done.back().latent;
      warm->set_bone_transforms(done.back().bones);
      Eigen::Matrix3Xd state, surface;
      if (first < n && !warm->Simulate(z, &state, &surface, &error)) {
        return fail(JobStatus::kNotConverged, "the last frame done, " + frames[first - 1].name +
                                                  ", cannot be simulated again: " + error);
      }
    }
  }
  // Fits frame f into *block (FrameBlockSize numbers: see PackFrame); false with
  // *status and *message if it cannot be fitted.
  auto fit_frame = [&](int f, std::vector<double>* block, JobStatus* status,
                       std::string* message) {
    const SequenceFrame& frame = frames[f];
    WallTimer frame_timer;
    const bool is_cloud = frame.kind == "points";
    std::unique_ptr<LatentFitter> own;
    LatentFitter* fitter = warm.get();
    if (!warm) {
      own = std::make_unique<LatentFitter>(model, options.fit);
      fitter = own.get();
      z = options.start.mean_latent ? fitter->MeanLatent() : fitter->PriorLatent();
    }
    std::string start = "previous";
    std::string fit_error;
    LatentFitResult fit;
    bool fitted = false;
    PointCloudFitOptions cloud_options = options.points;
    cloud_options.landmarks = frame.landmarks;
    if (!warm || f == 0) {  // from the start chosen for this frame
      fitted = FitFromChosenStart(fitter, is_cloud ? nullptr : &frame.target,
                                  is_cloud ? &frame.cloud : nullptr, cloud_options, options.start,
                                  z, &fit, &fit_error);
      if (fit.start.empty()) {  // no start could be simulated
        *status = JobStatus::kNotConverged;
        *message = frame.path + ": " + fit_error;
        return false;
      }
      start = fit.start;
    } else {
      fitted = is_cloud ? fitter->FitPointCloud(frame.cloud, cloud_options, z, &fit, &fit_error)
                        : fitter->Fit(frame.target, z, &fit, &fit_error);
    }
    if (!fitted) {
      *status = JobStatus::kNotConverged;
      *message = frame.path + ": " + fit_error + " (frames before it are written; rerun to retry)";
      return false;
    }
    if (warm) z = fit.latent;
    PackFrame(model, fit, start, frame_timer.Seconds(), block);
    return true;
  };

  const int block_size = FrameBlockSize(d, nb, ns);
  WallTimer timer;
  for (int begin = first; begin < n; begin += size) {
    const int end = std::min(n, begin + size);  // this round: frames [begin, end)
    const int mine = begin + rank;               // this rank's frame, if < end
    std::vector<double> block;
    JobStatus status = JobStatus::kOk;
    std::string message;
    const bool fitted = mine >= end || fit_frame(mine, &block, &status, &message);
    if (!fitted) block.assign(block_size, 0.0);  // sent, not written
    int first_failure = fitted ? n : mine;
    std::vector<double> blocks;
    if (distributed) {
      comm->MinToAll(&first_failure, 1);
      std::vector<int> counts(size, 0);
      for (int k = 0; k < end - begin; ++k) counts[k] = block_size;
      if (root) blocks.resize(static_cast<size_t>(block_size) * (end - begin));
      comm->GatherToRoot(block.data(), counts, blocks.data());
    } else {
      blocks = block;
    }
    // Rank 0 writes the round's frames before the first failing one: the OBJs, the
    // track, then the CSV rows (a frame is done once its row is there).
    const int written = std::min(end, first_failure);
    ok = true;
    if (root && written > begin) {
      for (int f = begin; f < written && ok; ++f) {
        const double* b = blocks.data() + static_cast<size_t>(block_size) * (f - begin);
        SurfaceMesh surface = model.neutral;
        surface.vertices = Eigen::Map<const Eigen::Matrix3Xd>(b + kFrameScalars + d + 6 * nb, 3, ns);
        ok = WriteObj(options.output_dir + "/" + frames[f].name + ".obj", surface, &error);
        track.col(f) = Eigen::Map<const Eigen::VectorXd>(b + kFrameScalars, d);
        csv += FrameRow(model, f, frames[f], b) + "\n";
      }
      ok = ok && WriteMatrixFile(options.output_dir + "/latents.bin", track.leftCols(written),
                                 &error);
      ok = ok && WriteFileAtomically(csv_path, csv, &error);
    }
    if (distributed) ok = comm->Agree(ok, &error);
    if (!ok) return fail(JobStatus::kBadInput, error);
    for (int f = begin; f < written; ++f) {
      ++result.frames_fitted;
      const double* b = blocks.data() + static_cast<size_t>(block_size) * (f - begin);
      if (!root) continue;
      const double elapsed = timer.Seconds();
      const double fps = result.frames_fitted / std::max(elapsed, 1e-9);
      log << "frame " << f + 1 << "/" << n << " " << frames[f].name << ": error mean "
          << std::setprecision(4) << b[2] << " over " << static_cast<int>(b[0]) << " points, "
          << static_cast<int>(b[5]) << " it, " << std::setprecision(3) << b[6] << " s";
      if (distributed) log << " (rank " << f - begin << ")";
      log << "; " << std::setprecision(3) << fps << " frames/s, ETA "
          << FormatSeconds((n - f - 1) / fps) << std::endl;
    }
    if (first_failure < n) {
      int code = static_cast<int>(status);
      if (distributed) {
        comm->BroadcastText(&message, first_failure - begin);
        comm->Broadcast(&code, 1, first_failure - begin);
      }
      return fail(static_cast<JobStatus>(code), message);
    }
  }
  result.seconds = timer.Seconds();
  result.frames_per_second = result.frames_fitted / std::max(result.seconds, 1e-9);
  if (first == n) {
    log << "all " << n << " frames were done already\n";
    if (root && !WriteMatrixFile(options.output_dir + "/latents.bin", track, &error)) ok = false;
    if (distributed) ok = comm->Agree(ok, &error);
    if (!ok) return fail(JobStatus::kBadInput, error);
  }
  log << "fitted " << result.frames_fitted << " frames in " << std::setprecision(4)
      << result.seconds << " s (" << result.frames_per_second << " frames/s); wrote "
      << options.output_dir << "/frames.csv, latents.bin and one OBJ per frame\n";
  return result;
}

bool FitSequenceOptions::Validate(std::string* error) const {
  return ValidateFitTargetOptions(target_kind, fit, points, error);
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
