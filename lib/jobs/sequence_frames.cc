#include "jobs/sequence_frames.h"

#include <cstdlib>
#include <filesystem>
#include <map>

#include "geometry/points_near_model.h"
#include "jobs/fit_job.h"
#include "jobs/fit_sequence.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "util/file_extension.h"
#include "util/file_list.h"
#include "util/fnv_hash.h"
#include "util/name_rules.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// The files of a sequence specification `spec` given to `flag` (--sequence: the
// frames, "target file"; --landmarks: "landmarks file"), with where each was listed
// (util/file_list.h: a folder's .obj, .txt and .ply files, a glob, a .txt list or a comma
// list).
bool ResolveFrames(const std::string& spec, const std::string& flag, const std::string& what,
                   std::vector<ListedFile>* out, std::string* error) {
  if (spec.empty()) {
    *error = "no sequence given";
    return false;
  }
  FileListOptions options;
  options.folder_extensions = {".obj", ".txt", ".ply"};
  options.what = what;
  options.list_hint = "; a .txt file given to " + flag + " lists the " + what +
                      "s, one per line: for a single " + what + " write '" + spec + ",'";
  if (!ResolveFileList(spec, options, out, error)) {
    *error = flag + ": " + *error;
    return false;
  }
  if (out->empty()) {
    *error = flag + "='" + spec + "' matches no " + what + "s (.obj, .txt, .ply)";
    return false;
  }
  return true;
}

// Prefixes an error about a listed file with where it was listed.
std::string From(const SequenceFrame& f, const std::string& message) {
  return f.origin == f.path ? message : f.origin + ": " + message;
}
// Adds what a fit reads of `target` to *h.
void AddTarget(const FitTarget& target, FnvHasher* h) {
  h->AddMatrix(target.vertices);
  h->AddMatrix(target.barycentric);
  h->AddMatrix(target.positions);
  h->AddMatrix(target.weights);
  h->AddMatrix(target.normals);
  h->Add(&target.tangential_weight, 1);
}

}  // namespace

bool ReadSequenceFrames(const FitSequenceOptions& options, const Eigen::Matrix3Xd& neutral,
                        std::vector<SequenceFrame>* frames, std::string* error) {
  const int ns = static_cast<int>(neutral.cols());
  std::vector<ListedFile> files;
  if (!ResolveFrames(options.sequence, "--sequence", "target file", &files, error)) return false;
  if (options.max_frames >= 0 && static_cast<int>(files.size()) > options.max_frames) {
    files.resize(options.max_frames);
  }
  if (files.empty()) {
    *error = options.sequence + ": no frames to fit (at most " +
             std::to_string(options.max_frames) + " asked for)";
    return false;
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
    const std::string problem = NameProblem(f.name);
    if (!problem.empty()) {
      *error = From(f, path + ": the frame name (the file's name) '" + f.name + "' " + problem);
      return false;
    }
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
        // The first frame decides; a later OBJ of another vertex count is a mismatch. An
        // OBJ within 1% of the neutral's vertex count (with or without faces) is a broken
        // pose rather than a scan, as for one target.
        const int n = surface.num_vertices();
        if (frames->empty() && n != ns && (surface.num_triangles() > 0 ||
                                           std::abs(n - ns) <= ns / 100)) {
          *error = From(f, path + ": a surface with " + std::to_string(n) +
                               " vertices, but the model's surface has " + std::to_string(ns) +
                               ": a pose target needs the neutral's vertex order; to fit the "
                               "files as point clouds (scans), pass --target_kind=points");
          return false;
        }
        const bool pose_sequence =
            frames->empty() ? n == ns : frames->front().kind == "pose";
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
      std::vector<int> all(ns);
      for (int v = 0; v < ns; ++v) all[v] = v;
      if (!CheckPointsNearModel(path, neutral, surface.vertices, error) ||
          !CheckTargetOffsetFromModel(path, neutral, all, surface.vertices, error)) {
        *error = From(f, *error);
        return false;
      }
      f.target = FullSurfaceTarget(surface.vertices);
    } else if (f.kind == "markers") {
      if (!ReadMarkerTarget(path, neutral, &f.target, error)) {
        *error = From(f, *error);
        return false;
      }
    } else {
      if (!ReadPointCloud(path, &f.cloud, error)) {
        *error = From(f, *error);
        return false;
      }
      if (f.cloud.cols() < 3) {
        *error = From(f, path + ": fewer than 3 points");
        return false;
      }
      if (!CheckPointsNearModel(path, neutral, f.cloud, error) ||
          !CheckTargetOffsetFromModel(path, neutral, {}, f.cloud, error)) {
        *error = From(f, *error);
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
  std::vector<ListedFile> landmark_files;
  if (!ResolveFrames(options.landmarks, "--landmarks", "landmarks file", &landmark_files,
                     error)) {
    return false;
  }
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
    // Not in the folder the outputs go to: the run's own files there (key.txt, frame
    // OBJs) would be taken for landmarks by the next run, which then cannot resume.
    std::error_code code;
    const fs::path folder = fs::path(path).parent_path();
    if (!options.output_dir.empty() &&
        fs::equivalent(options.output_dir, folder.empty() ? fs::path(".") : folder, code)) {
      *error = options.output_dir + ": is the folder of the landmarks file " + path +
               "; write the outputs elsewhere";
      return false;
    }
    if (!ReadMarkerTarget(path, neutral, &(*frames)[k].landmarks, error)) {
      if (origin != path) *error = origin + ": " + *error;
      return false;
    }
  }
  return true;
}

uint64_t FrameTargetFingerprint(const SequenceFrame& frame) {
  FnvHasher h;
  h.Add(frame.kind);
  AddTarget(frame.target, &h);
  h.AddMatrix(frame.cloud);
  AddTarget(frame.landmarks, &h);
  return h.hash();
}

}  // namespace aqs
