#ifndef AQS_UTIL_JOB_STATUS_H_
#define AQS_UTIL_JOB_STATUS_H_

namespace aqs {

// How a job (lib/jobs, the prepare job) ended; the apps exit with this number
// (apps/app_common.h, ExitStatus).
enum class JobStatus {
  kOk = 0,
  // Unreadable or invalid input (a file, an option), an output that cannot be
  // written, or work above a resource limit: nothing was computed, or the outputs
  // could not be written.
  kBadInput = 1,
  // A solve did not converge (an equilibrium, a fit): the outputs are still written,
  // for inspection.
  kNotConverged = 2,
  // K not positive definite at the solution: no gradient (aqs_simulate).
  kDifferentiationFailed = 3
};

}  // namespace aqs

#endif  // AQS_UTIL_JOB_STATUS_H_
