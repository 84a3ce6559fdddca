#ifndef AQS_APPS_FIT_FLAGS_H_
#define AQS_APPS_FIT_FLAGS_H_

#include <string>

#include "app_common.h"
#include "fit/latent_fit.h"
#include "latent_fit_flags.h"

namespace aqs {

// The fit options of aqs_fit and aqs_bench_fit from their shared flags (fit_flags.cc,
// and latent_fit_flags.cc for `fit`).
// Returns false with *error naming the flag for a bad value.
bool FitOptionsFromFlags(LatentFitOptions* fit, PointCloudFitOptions* points,
                         FitStartOptions* start, std::string* error);

// --temporal_prior (FitSequenceOptions::temporal_prior; aqs_bench_fit's sequence).
double TemporalPriorFlag();

// The fit jobs' option fields ("fit.", "points.", FitJobOptions' and
// FitSequenceOptions') and the flags that set them (for FlagError).
FlagNames FitFlagNames();

}  // namespace aqs

#endif  // AQS_APPS_FIT_FLAGS_H_
