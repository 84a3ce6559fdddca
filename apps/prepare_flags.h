#ifndef AQS_APPS_PREPARE_FLAGS_H_
#define AQS_APPS_PREPARE_FLAGS_H_

#include <string>

#include "app_common.h"
#include "jobs/prepare_job.h"

namespace aqs {

// PrepareJobOptions from the aqs_prepare flags (defined in prepare_flags.cc). Returns
// false with *error for missing or malformed flags.
bool PrepareOptionsFromFlags(PrepareJobOptions* options, std::string* error);

// Only what a rank other than 0 of a distributed prepare uses (targets, num_threads;
// PrepareJobOptions::communicator): from the flags alone, no file read.
bool PrepareTargetOptionsFromFlags(PrepareJobOptions* options, std::string* error);

// PrepareJobOptions' fields and the aqs_prepare flags that set them (for FlagError).
FlagNames PrepareFlagNames();

}  // namespace aqs

#endif  // AQS_APPS_PREPARE_FLAGS_H_
