#include "jobs/fit_sequence.h"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <sstream>

#include <Eigen/Geometry>

#include "jobs/fit_job.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/number_format.h"
#include "util/wall_timer.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

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
      const std::string ext = Lower(entry.path().extension().string());
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
  } else if (Lower(fs::path(spec).extension().string()) == ".txt" && spec.find(',') == std::string::npos) {
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
    std::stringstream list(spec);
    std::string item;
    while (std::getline(list, item, ',')) {
      if (item.empty()) continue;
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

// A CSV number (17 significant digits).
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
    std::vector<std::string> cells;
    std::stringstream s(reader.line());
    std::string cell;
    while (std::getline(s, cell, ',')) cells.push_back(cell);
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
    const std::string ext = Lower(fs::path(path).extension().string());
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
  return true;
}

FitSequenceResult RunFitSequence(const FitSequenceOptions& options, const ActiveModel& model,
                                 std::ostream& log) {
  FitSequenceResult result;
  auto fail = [&](JobStatus status, const std::string& message) {
    result.status = status;
    result.message = message;
    return result;
  };
  if (options.output_dir.empty()) return fail(JobStatus::kBadInput, "--output_dir is required");
  if (!model.decoder) return fail(JobStatus::kBadInput, options.model + ": the model is not trained");
  std::string error;
  std::vector<SequenceFrame> frames;
  if (!ReadSequenceFrames(options, model.num_surface_vertices(), &frames, &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  for (const SequenceFrame& f : frames) result.frame_names.push_back(f.name);
  std::error_code code;
  fs::create_directories(options.output_dir, code);
  if (code) {
    return fail(JobStatus::kBadInput,
                options.output_dir + ": cannot create the folder (" + code.message() + ")");
  }
  const std::string csv_path = options.output_dir + "/frames.csv";
  std::vector<DoneRow> done;
  if (!ReadDone(csv_path, options.output_dir, model, frames, &done, &error)) {
    return fail(JobStatus::kBadInput, error);
  }
  const int n = static_cast<int>(frames.size());
  const int d = model.latent_dim();
  std::vector<std::string> bone_names;
  for (const Bone& b : model.bones) bone_names.push_back(b.name);
  log << "sequence " << options.sequence << ": " << n << " " << frames.front().kind
      << " frames -> " << options.output_dir << "\n";

  LatentFitter fitter(model, options.fit);
  Eigen::VectorXd z = options.start.mean_latent ? fitter.MeanLatent() : fitter.PriorLatent();
  std::string csv = CsvHeader(model) + "\n";
  Eigen::MatrixXd track(d, n);
  for (size_t f = 0; f < done.size(); ++f) {
    csv += done[f].line + "\n";
    track.col(f) = done[f].latent;
  }
  const int first = static_cast<int>(done.size());
  result.frames_resumed = first;
  if (first > 0) {
    // Warm start from the last frame done: its latent and bones, its equilibrium
    // simulated again.
    log << "resuming at frame " << first << " (" << frames[first < n ? first : n - 1].name
        << "): " << first << " frames done\n";
    z = done.back().latent;
    fitter.set_bone_transforms(done.back().bones);
    Eigen::Matrix3Xd state, surface;
    if (first < n && !fitter.Simulate(z, &state, &surface, &error)) {
      return fail(JobStatus::kNotConverged, "the last frame done, " + frames[first - 1].name +
                                                ", cannot be simulated again: " + error);
    }
  }
  WallTimer timer;
  for (int f = first; f < n; ++f) {
    const SequenceFrame& frame = frames[f];
    WallTimer frame_timer;
    const bool is_cloud = frame.kind == "points";
    std::string start = "previous";
    if (f == 0) {
      if (!fitter.ChooseStart(is_cloud ? nullptr : &frame.target, is_cloud ? &frame.cloud : nullptr,
                              options.points, options.start, &z, &start, &error)) {
        return fail(JobStatus::kNotConverged, frame.path + ": " + error);
      }
    }
    LatentFitResult fit;
    const bool ok = is_cloud ? fitter.FitPointCloud(frame.cloud, options.points, z, &fit, &error)
                             : fitter.Fit(frame.target, z, &fit, &error);
    if (!ok) {
      return fail(JobStatus::kNotConverged,
                  frame.path + ": " + error + " (frames before it are written; rerun to retry)");
    }
    z = fit.latent;
    // Outputs: the OBJ, the track, then the CSV row (a frame is done once it is there).
    SurfaceMesh surface = model.neutral;
    surface.vertices = fit.surface;
    if (!WriteObj(options.output_dir + "/" + frame.name + ".obj", surface, &error)) {
      return fail(JobStatus::kBadInput, error);
    }
    track.col(f) = fit.latent;
    if (!WriteMatrixFile(options.output_dir + "/latents.bin", track.leftCols(f + 1), &error)) {
      return fail(JobStatus::kBadInput, error);
    }
    const double seconds = frame_timer.Seconds();
    std::string row = std::to_string(f) + "," + frame.name + "," + frame.kind + "," +
                      std::to_string(is_cloud ? frame.cloud.cols() : frame.target.num_points()) +
                      "," + std::to_string(fit.used_points);
    Append(fit.matched_fraction, &row);
    Append(fit.mean_error, &row);
    Append(fit.rms_error, &row);
    Append(fit.max_error, &row);
    row += "," + std::to_string(fit.iterations);
    Append(seconds, &row);
    row += std::string(",") + (fit.converged ? "1" : "0") + "," + start + "," +
           std::to_string(fit.solve_factorizations + fit.jacobians);
    for (int i = 0; i < d; ++i) Append(fit.latent[i], &row);
    for (const RigidTransform& t : fit.bones) {
      double p[6];
      BoneTransformToParameters(t, p);
      for (double v : p) Append(v, &row);
    }
    csv += row + "\n";
    if (!WriteFileAtomically(csv_path, csv, &error)) return fail(JobStatus::kBadInput, error);
    ++result.frames_fitted;
    const double elapsed = timer.Seconds();
    const double fps = result.frames_fitted / std::max(elapsed, 1e-9);
    log << "frame " << f + 1 << "/" << n << " " << frame.name << ": error mean "
        << std::setprecision(4) << fit.mean_error << " over " << fit.used_points << " points, "
        << fit.iterations << " it, " << std::setprecision(3) << seconds << " s; "
        << std::setprecision(3) << fps << " frames/s, ETA " << FormatSeconds((n - f - 1) / fps)
        << std::endl;
  }
  result.seconds = timer.Seconds();
  result.frames_per_second = result.frames_fitted / std::max(result.seconds, 1e-9);
  if (first == n) {
    log << "all " << n << " frames were done already\n";
    if (!WriteMatrixFile(options.output_dir + "/latents.bin", track, &error)) {
      return fail(JobStatus::kBadInput, error);
    }
  }
  log << "fitted " << result.frames_fitted << " frames in " << std::setprecision(4)
      << result.seconds << " s (" << result.frames_per_second << " frames/s); wrote "
      << options.output_dir << "/frames.csv, latents.bin and one OBJ per frame\n";
  return result;
}

bool FitSequenceOptions::Validate(std::string* error) const {
  std::string fit_error, points_error;
  const bool fit_ok = fit.Validate(&fit_error);
  const bool points_ok = points.Validate(&points_error);
  return OptionChecks()
      .Require(target_kind == "auto" || target_kind == "pose" || target_kind == "markers" ||
                   target_kind == "points",
               "target_kind must be auto, pose, markers or points (is '" + target_kind + "')")
      .Nested("fit", fit_ok, fit_error)
      .Nested("points", points_ok, points_error)
      .Done(error);
}

FitSequenceResult RunFitSequenceJob(const FitSequenceOptions& options, std::ostream& log) {
  FitSequenceResult result;
  if (!options.Validate(&result.message)) {
    result.status = JobStatus::kBadInput;
    return result;
  }
  if (options.model.empty() || options.sequence.empty() || options.output_dir.empty()) {
    result.status = JobStatus::kBadInput;
    result.message = "--model, --sequence and --output_dir are required";
    return result;
  }
  ActiveModel model;
  std::string error;
  if (!LoadModel(options.model, &model, &error)) {
    result.status = JobStatus::kBadInput;
    result.message = error;
    return result;
  }
  return RunFitSequence(options, model, log);
}

}  // namespace aqs
