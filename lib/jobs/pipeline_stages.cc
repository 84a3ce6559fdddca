#include "jobs/pipeline_stages.h"

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "model/model_directory.h"

namespace aqs {

namespace {

const std::vector<std::string>& StageOrder() {
  static const std::vector<std::string> kOrder = {"prepare", "pretrain", "train", "evaluate"};
  return kOrder;
}

}  // namespace

bool PipelineStages::WritesModel() const {
  return std::any_of(stages.begin(), stages.end(), [](const std::string& stage) {
    return stage == "prepare" || stage == "pretrain" || stage == "train";
  });
}

bool PipelineStages::Prepares() const {
  return std::find(stages.begin(), stages.end(), "prepare") != stages.end();
}

bool ParsePipelineStages(const std::vector<std::string>& names, PipelineStages* stages,
                         std::string* error) {
  const std::vector<std::string>& order = StageOrder();
  stages->stages.clear();
  if (names.empty()) {
    *error = "--stages: no stage given";
    return false;
  }
  int last = -1;
  for (const std::string& name : names) {
    const auto known = std::find(order.begin(), order.end(), name);
    if (known == order.end()) {
      *error = "--stages: unknown stage '" + name + "' (known: prepare, pretrain, train, evaluate)";
      return false;
    }
    const int index = static_cast<int>(known - order.begin());
    if (index <= last) {
      *error = "--stages: '" + name + "' after a later stage or twice (the order is prepare, "
               "pretrain, train, evaluate)";
      return false;
    }
    last = index;
  }
  stages->stages = names;
  return true;
}

bool LockPipelineModel(const PipelineStages& stages, const std::string& model_directory,
                       std::ostream* log, PathLock* lock, std::string* error) {
  if (!stages.WritesModel() || model_directory.empty()) return true;
  std::string model = model_directory;
  while (model.size() > 1 && model.back() == '/') model.pop_back();
  std::error_code code;
  const std::filesystem::path parent =
      std::filesystem::absolute(model, code).lexically_normal().parent_path();
  if (code) return true;  // the job names the path
  if (stages.Prepares()) std::filesystem::create_directories(parent, code);
  if (!std::filesystem::is_directory(parent, code)) return true;
  return LockModelForWriting(model, log, lock, error);
}

}  // namespace aqs
