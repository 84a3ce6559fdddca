#ifndef AQS_APPS_LEARNING_FLAGS_H_
#define AQS_APPS_LEARNING_FLAGS_H_

#include <string>

#include "eval/error_budget.h"
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

}  // namespace aqs

#endif  // AQS_APPS_LEARNING_FLAGS_H_
