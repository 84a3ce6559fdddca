#ifndef AQS_APPS_LEARNING_FLAGS_H_
#define AQS_APPS_LEARNING_FLAGS_H_

#include <string>

#include "train/pretrain.h"
#include "train/trainer.h"

namespace aqs {

// Options of aqs_pretrain / aqs_train from their flags (learning_flags.cc). Return
// false with *error for malformed flags.
bool PretrainOptionsFromFlags(PretrainOptions* options, std::string* error);
bool TrainOptionsFromFlags(TrainOptions* options, std::string* error);

}  // namespace aqs

#endif  // AQS_APPS_LEARNING_FLAGS_H_
