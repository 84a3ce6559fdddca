#ifndef AQS_PREPARE_POSE_FILES_H_
#define AQS_PREPARE_POSE_FILES_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// Resolves a pose-set specification into OBJ paths, sorted:
//   a directory        every "*.obj" file in it;
//   a glob pattern     (contains '*', '?' or '[') the matching files;
//   a ".txt" file      one path per line ('#' comments; relative paths are relative to
//                      `base_dir` if given, else to the list file's folder; a line
//                      without an extension gets ".obj");
//   otherwise          a comma-separated list of paths.
// Files whose name matches `exclude` (a glob on the file name, e.g. "*.teeth.obj";
// empty: none) are left out. Returns false with *error if nothing matches or a listed
// file does not exist.
bool ResolvePosePaths(const std::string& spec, const std::string& exclude,
                      std::vector<std::string>* paths, std::string* error,
                      const std::string& base_dir = "");

// The pose name of a path: the file name without its last extension ("a/jawOpen.obj"
// -> "jawOpen"). Names must be one word without '#' or ',' (util/name_rules.h).
std::string PoseNameFromPath(const std::string& path);

// Reads pose surfaces (OBJ, only the 'v' records matter) that must have
// `num_vertices` vertices each. names[i] = PoseNameFromPath(paths[i]); duplicated names
// and wrong vertex counts are errors naming the file. Threads: up to num_threads.
bool ReadPoseSurfaces(const std::vector<std::string>& paths, int num_vertices, int num_threads,
                      std::vector<std::string>* names, std::vector<Eigen::Matrix3Xd>* surfaces,
                      std::string* error);

}  // namespace aqs

#endif  // AQS_PREPARE_POSE_FILES_H_
