#include "app_common.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <gflags/gflags.h>
#include <glog/logging.h>

#include "all_flags.h"
#include "util/allocation_policy.h"
#include "util/line_reader.h"
#include "util/text_split.h"

DEFINE_string(model, "", "Model directory (written by aqs_prepare, read and updated by the "
              "later stages).");
DEFINE_string(pose_dir, "", "Folder that relative entries of .txt pose lists (--poses, "
              "--test_poses) are resolved in (default: the list file's folder).");
DEFINE_string(solver, "newton", "How equilibria are solved: 'newton' (L-BFGS preconditioned by "
              "the rotation-fixed stiffness far from equilibrium, then Newton steps, exact or "
              "PSD-projected, with a line search; needs fixed vertices) or 'lm' (Ceres' "
              "Levenberg-Marquardt, then exact Newton; also for free bodies).");
DEFINE_bool(negative_curvature_steps, false, "Newton: where the exact stiffness stays "
            "indefinite on a retry, step along its direction of most negative curvature instead "
            "of a projected step (leaves saddles and crawls near buckling in a few "
            "factorizations; docs/solver.md). Unset: each stage's own default (on for contact "
            "solves, off elsewhere).");
DEFINE_int32(newton_stall_steps, aqs::QuasistaticSolverOptions::kDefaultNewtonStallSteps,
             "Newton: a phase stops, not converged, after this many "
             "backtracked steps without progress (where the energy has a kink, as a contact's "
             "closest feature switching, the force cannot fall further; docs/solver.md). 0: "
             "never (the factorization budget ends such a phase).");
DEFINE_int32(threads, 2, "Threads (per-element work, parallel poses; BLAS follows OPENBLAS_NUM_THREADS).");
DEFINE_double(max_memory_gb, 8.0, "Memory limit in GB: the work whose memory is estimated before "
              "it is allocated (prepare's lattice and simulations, pre-training's decoder, the "
              "evaluation's auto-encoder baseline, the benchmarks' lattices) is refused with "
              "exit status 1 and the estimate above it.");

namespace aqs {
namespace {

// gflags reads a --flagfile's flags but passes over names it does not know, where the
// same flag on the command line is an error: a misspelt flag in a config would silently
// keep its default. Checks every "--name[=value]" line of the flagfiles in `list`
// (comma-separated; nested --flagfile lines too): the name must be a flag of this app,
// or of another ActiveQS app (kAllAppFlagNames: a flagfile is shared by the stages).
// `chain` holds the flagfiles that include this list, outermost first (canonical paths):
// a file among them would include itself, which gflags follows until its stack
// overflows, so this runs before gflags reads them. False with *error at file:line.
bool CheckFlagfiles(const std::string& list, std::vector<std::string>* chain,
                    std::string* error) {
  if (chain->size() > 8) {
    *error = "--flagfile: nested more than 8 deep";
    return false;
  }
  for (const std::string& path : SplitList(list)) {
    std::error_code code;
    const std::string canonical = std::filesystem::weakly_canonical(path, code).string();
    const std::string key = code ? path : canonical;
    if (std::find(chain->begin(), chain->end(), key) != chain->end()) {
      std::string through;
      for (const std::string& file : *chain) through += file + " -> ";
      *error = "--flagfile: " + path + " includes itself (" + through + key + ")";
      return false;
    }
    LineReader reader(path);
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    while (reader.NextLine()) {
      std::string line = reader.line();
      line.erase(0, line.find_first_not_of(" \t"));
      while (!line.empty() && (line.back() == ' ' || line.back() == '\t' || line.back() == '\r')) {
        line.pop_back();
      }
      if (line.empty() || line[0] == '#') continue;  // blank or a comment
      // gflags reads a line that is not a flag as a filter of program names, and skips
      // every flag after it that the filter does not match: refused.
      if (line[0] != '-' || line.size() < 2) {
        *error = reader.Where("'" + line + "' is not a flag (a flagfile holds --name=value "
                              "lines and # comments)");
        return false;
      }
      const size_t start = line.find_first_not_of('-');
      if (start == std::string::npos) {
        *error = reader.Where("'" + line + "' is not a flag (a flagfile holds --name=value "
                              "lines and # comments)");
        return false;
      }
      const size_t end = line.find_first_of("= \t", start);
      const std::string name = line.substr(start, end == std::string::npos ? end : end - start);
      // gflags drops "--name value" and a non-bool "--name" inside a flagfile, keeping the
      // default; and a "# comment" after a value becomes part of it.
      if (end != std::string::npos && line[end] != '=') {
        *error = reader.Where("--" + name + ": write --" + name + "=value (in a flagfile a "
                              "space does not separate a flag from its value)");
        return false;
      }
      if (end != std::string::npos && line.find(" #", end) != std::string::npos) {
        *error = reader.Where("--" + name + ": a '#' comment after a value would be part of "
                              "it (put comments on lines of their own)");
        return false;
      }
      gflags::CommandLineFlagInfo info;
      bool known = gflags::GetCommandLineFlagInfo(name.c_str(), &info);
      if (!known && name.compare(0, 2, "no") == 0 &&
          gflags::GetCommandLineFlagInfo(name.substr(2).c_str(), &info)) {
        // --noflag: for a bool only (gflags drops it for another type, in a flagfile).
        if (info.type != "bool") {
          *error = reader.Where("--" + name + ": --" + name.substr(2) + " is not a bool flag "
                                "(write --" + name.substr(2) + "=value)");
          return false;
        }
        known = true;
      }
      // Another app's flag (this app does not link it, so its type is not known here).
      for (const char* app_flag : kAllAppFlagNames) {
        known = known || name == app_flag ||
                (info.type.empty() && name.compare(0, 2, "no") == 0 && name.substr(2) == app_flag);
      }
      if (!known) {
        *error = reader.Where("unknown flag --" + name + " (no ActiveQS app has it)");
        return false;
      }
      if (end == std::string::npos && !info.type.empty() && info.type != "bool" &&
          name.compare(0, 2, "no") != 0) {
        *error = reader.Where("--" + name + " needs a value (--" + name + "=value)");
        return false;
      }
      if (name == "flagfile" && end != std::string::npos) {
        chain->push_back(key);
        const bool nested_ok = CheckFlagfiles(line.substr(end + 1), chain, error);
        chain->pop_back();
        if (!nested_ok) return false;
      }
    }
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
  }
  return true;
}

}  // namespace

void InitApp(const std::string& usage, int* argc, char*** argv) {
  // Line-buffered standard output, as on a terminal, also into a file or a pipe: a long
  // run's log shows each line as it is printed, and a killed run keeps what it printed.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  // Large blocks (L-BFGS vectors of millions of parameters) from the heap and reused, not
  // mapped and zeroed again at every step (util/allocation_policy.h).
  ReuseLargeAllocations(kAppKeptAllocationBytes);
  gflags::SetUsageMessage(usage);
  // Every flagfile of the command line, in order (gflags keeps only the last one it read
  // in --flagfile, and a file that includes another would go unchecked).
  std::string flagfiles;
  for (int i = 1; i < *argc; ++i) {
    const std::string argument = (*argv)[i];
    for (const char* prefix : {"--flagfile=", "-flagfile="}) {
      if (argument.rfind(prefix, 0) == 0) {
        flagfiles += (flagfiles.empty() ? "" : ",") + argument.substr(std::strlen(prefix));
      }
    }
    if ((argument == "--flagfile" || argument == "-flagfile") && i + 1 < *argc) {
      flagfiles += (flagfiles.empty() ? "" : ",") + std::string((*argv)[i + 1]);
    }
  }
  // Before gflags reads them: it follows a flagfile that includes itself until its stack
  // overflows.
  std::string flagfile_error;
  std::vector<std::string> chain;
  if (!flagfiles.empty() && !CheckFlagfiles(flagfiles, &chain, &flagfile_error)) {
    std::fprintf(stderr, "%s: error: %s\n",
                 std::filesystem::path((*argv)[0]).filename().c_str(), flagfile_error.c_str());
    std::exit(1);
  }
  gflags::ParseCommandLineNonHelpFlags(argc, argv, true);
  // gflags' own --helpshort lists only the flags of the file holding main(). An app also
  // takes the shared flags of apps/app_common.cc and of the apps/*_flags.cc units it
  // links (one per stage: prepare, learning, evaluate, fit, mpi), so list every flag
  // defined under apps/, grouped by the file that defines it.
  std::string helpshort;
  if (gflags::GetCommandLineOption("helpshort", &helpshort) && helpshort == "true") {
    gflags::ShowUsageWithFlagsRestrict((*argv)[0], "apps/");
    std::exit(1);  // as gflags' --help and --helpshort
  }
  gflags::HandleCommandLineHelpFlags();
  FLAGS_logtostderr = true;
  // Warnings and errors; with glog's --v > 0, also the verbose lines (VLOG) and INFO.
  FLAGS_minloglevel = FLAGS_v > 0 ? 0 : 1;
  google::InitGoogleLogging((*argv)[0]);
  if (*argc > 1) {
    std::fprintf(stderr, "%s: error: unexpected argument '%s' (flags are --name=value)\n",
                 gflags::ProgramInvocationShortName(), (*argv)[1]);
    std::exit(1);
  }
  // Every app takes it (some estimate no memory): checked in one place, in the flag's
  // own unit (GB).
  if (!(FLAGS_max_memory_gb > 0) || !std::isfinite(FLAGS_max_memory_gb)) {
    std::fprintf(stderr, "%s: error: --max_memory_gb must be finite and > 0 (is %g)\n",
                 gflags::ProgramInvocationShortName(), FLAGS_max_memory_gb);
    std::exit(1);
  }
}

bool RefuseSolverMethodFlags(std::string* error) {
  for (const char* flag : {"solver", "negative_curvature_steps", "newton_stall_steps"}) {
    if (!gflags::GetCommandLineFlagInfoOrDie(flag).is_default) {
      *error = std::string("--") + flag + " does not apply here: this benchmark sets its "
               "solves' methods itself";
      return false;
    }
  }
  return true;
}

bool SolverMethodFromFlag(QuasistaticSolverOptions* options, std::string* error) {
  if (FLAGS_solver == "newton") {
    options->method = EquilibriumMethod::kNewton;
  } else if (FLAGS_solver == "lm") {
    options->method = EquilibriumMethod::kLevenbergMarquardt;
  } else {
    *error = "--solver must be 'newton' or 'lm' (is '" + FLAGS_solver + "')";
    return false;
  }
  // Only where given: contact solves default to on (DefaultContactSolverOptions).
  if (!gflags::GetCommandLineFlagInfoOrDie("negative_curvature_steps").is_default) {
    options->negative_curvature_steps = FLAGS_negative_curvature_steps;
  }
  if (FLAGS_newton_stall_steps < 0) {
    *error = "--newton_stall_steps must be >= 0 (is " + std::to_string(FLAGS_newton_stall_steps) +
             ")";
    return false;
  }
  options->newton_stall_steps = FLAGS_newton_stall_steps;
  return true;
}

void PrintError(const std::string& message) {
  std::fprintf(stderr, "%s: error: %s\n", gflags::ProgramInvocationShortName(), message.c_str());
}

int ExitStatus(JobStatus status) {
  switch (status) {
    case JobStatus::kOk:
      return 0;
    case JobStatus::kBadInput:
      return 1;
    case JobStatus::kNotConverged:
      return 2;
    case JobStatus::kDifferentiationFailed:
      return 3;
  }
  return 1;
}

FlagNames CommonFlagNames(const std::string& prefix) {
  return {{prefix + "num_threads", "--threads"},
          {prefix + "solver.num_threads", "--threads"},
          {"max_memory_bytes", "--max_memory_gb"},
          {prefix + "max_memory_bytes", "--max_memory_gb"}};
}

namespace {

// Whether `text`, which starts with an options field `field`, names that field rather
// than a file: the field is followed by the end, ' ', ',' or '=', by ": " (not a line
// number, "mu:3:") where no file or folder of that name is where the app runs (a path's
// "mu: cannot read ..."), or by '.' and a sub-field name that a space, ',', '=' or the
// end follows ("lattice.nx must", not the file "mu.txt:3:").
bool StartsWithField(const std::string& text, const std::string& field) {
  if (text.compare(0, field.size(), field) != 0) return false;
  const size_t n = field.size();
  auto ends_word = [&](size_t pos) {
    return pos == text.size() || std::strchr(" ,=", text[pos]) != nullptr;
  };
  bool field_like = false;
  if (ends_word(n)) {
    field_like = true;
  } else if (text[n] == ':') {
    // Only this form can be a path's message ("mu: cannot read ..." of a file named mu).
    std::error_code ignored;
    field_like = (n + 1 == text.size() || text[n + 1] == ' ') &&
                 !std::filesystem::exists(field, ignored);
  } else if (text[n] == '.') {
    size_t pos = n + 1;
    while (pos < text.size() && (std::islower(static_cast<unsigned char>(text[pos])) ||
                                 text[pos] == '_')) {
      ++pos;
    }
    field_like = pos > n + 1 && ends_word(pos);
  }
  return field_like;
}

}  // namespace

std::string FlagError(const std::string& message, const FlagNames& flags) {
  std::string text = message;
  // At the start: the longest field that names a field, not a file.
  size_t best = 0;
  const std::string* flag = nullptr;
  for (const auto& [field, name] : flags) {
    if (field.size() > best && StartsWithField(text, field)) {
      best = field.size();
      flag = &name;
    }
  }
  if (flag != nullptr) text = *flag + text.substr(best);
  // In parentheses.
  for (const auto& [field, name] : flags) {
    const std::string quoted = "(" + field + ")";
    for (size_t pos; (pos = text.find(quoted)) != std::string::npos;) {
      text.replace(pos, quoted.size(), "(" + name + ")");
    }
  }
  return text;
}

int FinishJob(JobStatus status, const std::string& message, const FlagNames& flags) {
  if (status != JobStatus::kOk) PrintError(FlagError(message, flags));
  return ExitStatus(status);
}

double MaxMemoryBytes() { return FLAGS_max_memory_gb * 1e9; }

}  // namespace aqs
