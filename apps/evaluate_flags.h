#ifndef AQS_APPS_EVALUATE_FLAGS_H_
#define AQS_APPS_EVALUATE_FLAGS_H_

#include <string>

#include "app_common.h"
#include "jobs/evaluate_job.h"

namespace aqs {

// EvaluateJobOptions from the aqs_evaluate flags (evaluate_flags.cc).
bool EvaluateOptionsFromFlags(EvaluateJobOptions* options, std::string* error);

// EvaluateJobOptions' fields and the aqs_evaluate flags that set them (for FlagError).
FlagNames EvaluateFlagNames();

}  // namespace aqs

#endif  // AQS_APPS_EVALUATE_FLAGS_H_
