#include "model/model_files.h"

#include <cstdio>

namespace aqs {
namespace internal {

std::string PoseFile(const std::string& folder, int p) {
  char name[32];
  std::snprintf(name, sizeof(name), "%04d.bin", p);
  return folder + "/" + name;
}

std::vector<std::string> BoneNames(const ActiveModel& model) {
  std::vector<std::string> names;
  for (const Bone& bone : model.bones) names.push_back(bone.name);
  return names;
}

}  // namespace internal
}  // namespace aqs
