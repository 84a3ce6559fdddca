#ifndef AQS_APPS_APP_COMMON_H_
#define AQS_APPS_APP_COMMON_H_

#include <string>
#include <utility>
#include <vector>

#include "equilibrium/quasistatic_solver.h"
#include "util/job_status.h"
#include "util/text_split.h"  // SplitList, which the apps use for list flags

namespace aqs {

// Sets options->method from --solver ("newton" or "lm") and, where the flag is given,
// options->negative_curvature_steps from --negative_curvature_steps (unset, the options'
// own value stays: contact solves default to on), and options->newton_stall_steps from
// --newton_stall_steps. Returns false with *error naming the flag for any other --solver
// value or a negative --newton_stall_steps.
bool SolverMethodFromFlag(QuasistaticSolverOptions* options, std::string* error);

// For apps whose solves choose their own method (the benchmarks: --methods, or the
// methods they compare): false with *error naming --solver, --negative_curvature_steps
// or --newton_stall_steps where one is given, which the app would otherwise ignore.
bool RefuseSolverMethodFlags(std::string* error);

// Makes standard output line-buffered (a log file shows each line as it is printed and
// keeps it if the process is killed), parses gflags (with `usage`), sets up glog to
// print warnings and errors on stderr.
// --helpshort lists every flag the app takes (its own, app_common.cc's and those of the
// apps/*_flags.cc units it links), grouped by defining file, and exits with status 1 as
// gflags' --help does. Exits with status 1 and a message if positional arguments are
// left over.
void InitApp(const std::string& usage, int* argc, char*** argv);

// Prints "<program>: error: <message>" to stderr.
void PrintError(const std::string& message);

// The one exit-status convention of the apps (docs/apps.md, "Exit status"): 0 done;
// 1 bad input (a file, a flag, an output that cannot be written, work above a resource
// limit); 2 a solve did not converge (the outputs are written for inspection); 3 no
// gradient (aqs_simulate).
int ExitStatus(JobStatus status);

// Option fields as the library's Validate() names them ("solver.num_threads",
// "max_memory_bytes") and the app's flag that sets each ("--threads",
// "--max_memory_gb").
using FlagNames = std::vector<std::pair<std::string, std::string>>;

// The flags every app shares (--threads, --max_memory_gb), with `prefix` before the
// field names (e.g. "solver." or "fit.").
FlagNames CommonFlagNames(const std::string& prefix = "");

// `message` with option field names turned into the app's flags: a field at the start
// of the message (followed by a space, ',', '=', ": ", or '.' and a sub-field name) or in
// parentheses "(field)". The longest matching field wins; other text is unchanged. A
// message that starts with a file's name is left alone: "mu.txt:3: ...", "mu:3: ...",
// or "mu: ..." where a file or folder `mu` exists.
std::string FlagError(const std::string& message, const FlagNames& flags);

// Ends a job: prints its message (FlagError) unless status is kOk, and returns
// ExitStatus(status).
int FinishJob(JobStatus status, const std::string& message, const FlagNames& flags);

// --max_memory_gb in bytes (any value; the jobs' Validate checks it).
double MaxMemoryBytes();

}  // namespace aqs

#endif  // AQS_APPS_APP_COMMON_H_
