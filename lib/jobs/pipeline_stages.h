#ifndef AQS_JOBS_PIPELINE_STAGES_H_
#define AQS_JOBS_PIPELINE_STAGES_H_

#include <ostream>
#include <string>
#include <vector>

#include "util/path_lock.h"

namespace aqs {

// What aqs_pipeline runs, in this order at most once each: prepare, pretrain, train,
// evaluate (docs/apps.md#aqs_pipeline).
struct PipelineStages {
  std::vector<std::string> stages;  // in order, a subsequence of the four

  // Whether a stage writes the model (prepare, pretrain, train) / prepares it.
  bool WritesModel() const;
  bool Prepares() const;
};

// Reads the stage names (as split from --stages) into *stages: false with *error
// ("--stages: ...") for an unknown stage, one out of order or given twice, or none.
bool ParsePipelineStages(const std::vector<std::string>& names, PipelineStages* stages,
                         std::string* error);

// The hold the stages that write the model at `model_directory` keep for the whole run
// (LockModelForWriting, messages to `log`): nothing to hold (true, *lock untouched) when
// no stage writes, the path is empty or its parent folder does not exist (the job's
// own checks say why); the parent is made first when the stages prepare. False with
// *error when another writer holds the lock.
bool LockPipelineModel(const PipelineStages& stages, const std::string& model_directory,
                       std::ostream* log, PathLock* lock, std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_PIPELINE_STAGES_H_
