#include "app_common.h"

#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <gflags/gflags.h>
#include <glog/logging.h>

DEFINE_string(model, "", "Model directory (written by aqs_prepare, read and updated by the "
              "later stages).");
DEFINE_string(pose_dir, "", "Folder that relative entries of .txt pose lists (--poses, "
              "--test_poses) are resolved in (default: the list file's folder).");
DEFINE_string(solver, "newton", "How equilibria are solved: 'newton' (L-BFGS preconditioned by "
              "the rotation-fixed stiffness far from equilibrium, then Newton steps, exact or "
              "PSD-projected, with a line search; needs fixed vertices) or 'lm' (Ceres' "
              "Levenberg-Marquardt, then exact Newton; also for free bodies).");
DEFINE_int32(threads, 2, "Threads (per-element work, parallel poses; BLAS follows OPENBLAS_NUM_THREADS).");

namespace aqs {

void InitApp(const std::string& usage, int* argc, char*** argv) {
  gflags::SetUsageMessage(usage);
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
  FLAGS_minloglevel = 1;  // warnings and errors
  google::InitGoogleLogging((*argv)[0]);
  if (*argc > 1) {
    std::fprintf(stderr, "%s: error: unexpected argument '%s' (flags are --name=value)\n",
                 gflags::ProgramInvocationShortName(), (*argv)[1]);
    std::exit(1);
  }
}

std::vector<std::string> SplitCommaList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
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
  return true;
}

void PrintError(const std::string& message) {
  std::fprintf(stderr, "%s: error: %s\n", gflags::ProgramInvocationShortName(), message.c_str());
}

}  // namespace aqs
