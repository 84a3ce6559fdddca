#ifndef AQS_APPS_PREPARE_FLAGS_H_
#define AQS_APPS_PREPARE_FLAGS_H_

#include <string>

#include "app_common.h"
#include "jobs/prepare_job.h"
#include "prepare/volumetric_targets.h"

namespace aqs {

// PrepareJobOptions from the aqs_prepare flags (defined in prepare_flags.cc). Returns
// false with *error for missing or malformed flags.
bool PrepareOptionsFromFlags(PrepareJobOptions* options, std::string* error);

// The volumetric targets' options from the flags (--attachment_stiffness,
// --inverted_targets, --prepare_tolerance, --solver), for prepare's training poses
// and the evaluation's held-out ones alike (num_threads is the caller's). False with
// *error naming the flag.
bool VolumetricTargetOptionsFromFlags(VolumetricTargetOptions* options, std::string* error);

// Only what a rank other than 0 of a distributed prepare uses (targets, num_threads;
// PrepareJobOptions::communicator): from the flags alone, no file read.
bool PrepareTargetOptionsFromFlags(PrepareJobOptions* options, std::string* error);

// PrepareJobOptions' fields and the aqs_prepare flags that set them (for FlagError).
FlagNames PrepareFlagNames();

}  // namespace aqs

#endif  // AQS_APPS_PREPARE_FLAGS_H_
