#ifndef AQS_APPS_LEARNING_FLAGS_H_
#define AQS_APPS_LEARNING_FLAGS_H_

#include <string>

#include "app_common.h"
#include "eval/error_budget.h"
#include "jobs/learning_jobs.h"
#include "train/pretrain.h"
#include "train/trainer.h"

namespace aqs {

// Options of aqs_pretrain / aqs_train from their flags (learning_flags.cc). Return
// false with *error for malformed flags.
bool PretrainOptionsFromFlags(PretrainOptions* options, std::string* error);
bool TrainOptionsFromFlags(TrainOptions* options, std::string* error);
// How aqs_pretrain simulates the pre-trained poses (--pretrain_simulate: *enabled;
// --train_tolerance, --threads).
bool PretrainSimulationFromFlags(PoseSimulationOptions* options, bool* enabled,
                                 std::string* error);
// The decoder aqs_train expects: --latent_dim, --hidden and --activation where given on
// the command line or in a flagfile (not left at their defaults).
bool ExpectedDecoderFromFlags(ExpectedDecoder* expected, std::string* error);

// The options' fields and the flags that set them (for FlagError): RunPretrainJob's
// (PretrainOptions and "simulation." PoseSimulationOptions) and RunTrainJob's
// (TrainOptions and the expected decoder).
FlagNames PretrainFlagNames();
FlagNames TrainFlagNames();

}  // namespace aqs

#endif  // AQS_APPS_LEARNING_FLAGS_H_
