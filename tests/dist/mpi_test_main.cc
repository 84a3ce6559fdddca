// The main of the tests run under mpirun (tests/dist/CMakeLists.txt): starts MPI,
// runs every test on every rank (the ranks other than 0 print only failures), and
// exits non-zero on any rank that saw a failure (then mpirun does too).

#include <cstdio>
#include <sstream>

#include <gtest/gtest.h>

#include "dist/mpi_runtime.h"
#include "dist/mpi_world.h"
#include "testing/training_fixtures.h"

namespace aqs {
namespace testing {
Communicator* g_world = nullptr;  // set by main

const Communicator& World() { return *g_world; }

SharedTempDir::SharedTempDir() {
  if (World().is_root()) {
    dir_ = std::make_unique<TempDir>();
    path_ = dir_->path();
  }
  World().BroadcastText(&path_, 0);
}

ActiveModel PretrainedBar(int num_poses) {
  SyntheticBarSpec spec;
  spec.num_poses = num_poses;
  spec.activation = Activation::kTanh;
  spec.node_spacing = 0.35;
  spec.num_threads = 1;
  return PretrainedSyntheticBar(spec);
}

}  // namespace testing
}  // namespace aqs

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  std::string error;
  std::unique_ptr<aqs::Communicator> world = aqs::StartMpi(&argc, &argv, &error);
  if (!world) {
    std::fprintf(stderr, "aqs_mpi_test: %s\n", error.c_str());
    return 1;
  }
  // Every test compares ranks with one process: on one rank (a launcher that starts
  // singletons, or the binary run by hand) they would compare a process with itself.
  if (world->size() < 2) {
    std::fprintf(stderr, "aqs_mpi_test: %d rank; the tests need 2 or more (mpiexec -n 2)\n",
                 world->size());
    return 1;
  }
  aqs::testing::g_world = world.get();
  if (world->rank() != 0) GTEST_FLAG_SET(brief, true);
  const int status = RUN_ALL_TESTS();
  world->Barrier();
  return status;
}
