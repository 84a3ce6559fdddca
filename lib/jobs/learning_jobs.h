#ifndef AQS_JOBS_LEARNING_JOBS_H_
#define AQS_JOBS_LEARNING_JOBS_H_

#include <ostream>
#include <string>

#include "train/pretrain.h"
#include "train/trainer.h"

namespace aqs {

// aqs_pretrain as a library call: loads the model directory, pre-trains a new decoder
// and latents (train/pretrain.h), and saves the model (any earlier training checkpoint
// and states are discarded: they belong to the old decoder).
bool RunPretrainJob(const std::string& model_directory, const PretrainOptions& options,
                    std::ostream& log, std::string* error);

// aqs_train as a library call: loads the pre-trained model and trains it end to end
// (train/trainer.h) with checkpoints in the model directory. With restart, an earlier
// run's checkpoint count is ignored (the iterations start from 0 again; the learned
// state in the directory is still the starting point).
bool RunTrainJob(const std::string& model_directory, const TrainOptions& options, bool restart,
                 std::ostream& log, std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_LEARNING_JOBS_H_
