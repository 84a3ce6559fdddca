#ifndef AQS_APPS_APP_COMMON_H_
#define AQS_APPS_APP_COMMON_H_

#include <string>
#include <vector>

#include "equilibrium/quasistatic_solver.h"

namespace aqs {

// Sets options->method from --solver ("newton" or "lm"). Returns false with *error
// naming the flag for any other value.
bool SolverMethodFromFlag(QuasistaticSolverOptions* options, std::string* error);

// Parses gflags (with `usage`), sets up glog to print warnings and errors on stderr.
// --helpshort lists every flag the app takes (its own, app_common.cc's and those of the
// apps/*_flags.cc units it links), grouped by defining file, and exits with status 1 as
// gflags' --help does. Exits with status 1 and a message if positional arguments are
// left over.
void InitApp(const std::string& usage, int* argc, char*** argv);

// "a,b,,c" -> {"a", "b", "c"}.
std::vector<std::string> SplitCommaList(const std::string& text);

// Prints "<program>: error: <message>" to stderr.
void PrintError(const std::string& message);

}  // namespace aqs

#endif  // AQS_APPS_APP_COMMON_H_
