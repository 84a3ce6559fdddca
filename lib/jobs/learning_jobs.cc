#include "jobs/learning_jobs.h"

#include <filesystem>

#include "model/model_io.h"

namespace aqs {

bool RunPretrainJob(const std::string& model_directory, const PretrainOptions& options,
                    std::ostream& log, std::string* error) {
  ActiveModel model;
  if (!LoadModel(model_directory, &model, error)) return false;
  PretrainReport report;
  if (!Pretrain(options, &model, &report, log, error)) return false;
  if (!SaveModel(model_directory, model, error)) return false;
  log << "wrote model " << model_directory << "\n";
  return true;
}

bool RunTrainJob(const std::string& model_directory, const TrainOptions& options, bool restart,
                 std::ostream& log, std::string* error) {
  ActiveModel model;
  if (!LoadModel(model_directory, &model, error)) return false;
  if (restart) {
    std::error_code code;
    std::filesystem::remove(model_directory + "/train/checkpoint.txt", code);
  }
  TrainOptions train = options;
  train.model_directory = model_directory;
  TrainReport report;
  return TrainEndToEnd(train, &model, &report, log, error);
}

}  // namespace aqs
