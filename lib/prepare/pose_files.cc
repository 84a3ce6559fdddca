#include "prepare/pose_files.h"

#include <fnmatch.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include "mesh/mesh_io.h"
#include "util/file_list.h"
#include "util/name_rules.h"
#include "util/parallel_for.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

bool Excluded(const std::string& path, const std::string& exclude) {
  if (exclude.empty()) return false;
  const std::string name = fs::path(path).filename().string();
  return fnmatch(exclude.c_str(), name.c_str(), 0) == 0;
}

}  // namespace

std::string PoseNameFromPath(const std::string& path) {
  return fs::path(path).stem().string();
}

bool ResolvePosePaths(const std::string& spec, const std::string& exclude,
                      std::vector<std::string>* paths, std::string* error,
                      const std::string& base_dir) {
  if (spec.empty()) {
    *error = "no poses given";
    return false;
  }
  FileListOptions options;
  options.folder_extensions = {".obj"};
  options.default_extension = ".obj";
  options.base_dir = base_dir;
  options.what = "pose file";
  std::vector<ListedFile> files;
  if (!ResolveFileList(spec, options, &files, error)) return false;
  std::vector<std::string> found;
  for (const ListedFile& file : files) found.push_back(file.path);
  found.erase(std::remove_if(found.begin(), found.end(),
                             [&](const std::string& p) { return Excluded(p, exclude); }),
              found.end());
  std::sort(found.begin(), found.end());
  if (found.empty()) {
    *error = "the pose set '" + spec + "' matches no pose files" +
             (exclude.empty() ? "" : " (after excluding '" + exclude + "')");
    return false;
  }
  *paths = found;
  return true;
}

bool ReadPoseSurfaces(const std::vector<std::string>& paths, int num_vertices, int num_threads,
                      std::vector<std::string>* names, std::vector<Eigen::Matrix3Xd>* surfaces,
                      std::string* error) {
  const int n = static_cast<int>(paths.size());
  std::vector<std::string> read_names(n), errors(n);
  std::vector<Eigen::Matrix3Xd> read(n);
  std::set<std::string> seen;
  for (int i = 0; i < n; ++i) {
    read_names[i] = PoseNameFromPath(paths[i]);
    const std::string problem = NameProblem(read_names[i]);
    if (!problem.empty()) {
      *error = paths[i] + ": the pose name (the file's name) '" + read_names[i] + "' " + problem;
      return false;
    }
    if (!seen.insert(read_names[i]).second) {
      *error = paths[i] + ": a second pose named '" + read_names[i] + "'";
      return false;
    }
  }
  ParallelFor(num_threads, 0, n, [&](int, int i) {
    SurfaceMesh surface;
    if (!ReadObj(paths[i], &surface, &errors[i])) return;
    if (surface.num_vertices() != num_vertices) {
      std::ostringstream out;
      out << paths[i] << ": " << surface.num_vertices() << " vertices, but the neutral surface has "
          << num_vertices << " (poses must share the neutral's vertex order)";
      errors[i] = out.str();
      return;
    }
    read[i] = surface.vertices;
  }, 1);
  for (int i = 0; i < n; ++i) {
    if (!errors[i].empty()) {
      *error = errors[i];
      return false;
    }
  }
  *names = read_names;
  *surfaces = read;
  return true;
}

}  // namespace aqs
