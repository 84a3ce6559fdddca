#ifndef AQS_APPS_LATENT_FIT_FLAGS_H_
#define AQS_APPS_LATENT_FIT_FLAGS_H_

#include <string>

#include "app_common.h"
#include "fit/latent_fit.h"

namespace aqs {

// The options of a latent fit (priors, bones, iterations, tolerances) from the flags
// every app that fits the model shares (latent_fit_flags.cc): aqs_fit, aqs_bench_fit,
// and aqs_evaluate and aqs_pipeline for their held-out fits, so that one flag names
// one setting everywhere. Returns false with *error naming the flag for a bad value.
bool LatentFitOptionsFromFlags(LatentFitOptions* fit, std::string* error);

// LatentFitOptions' fields under `prefix` (e.g. "fit.") and the flags that set them
// (for FlagError).
FlagNames LatentFitFlagNames(const std::string& prefix);

}  // namespace aqs

#endif  // AQS_APPS_LATENT_FIT_FLAGS_H_
