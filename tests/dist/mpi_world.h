#ifndef AQS_TESTS_DIST_MPI_WORLD_H_
#define AQS_TESTS_DIST_MPI_WORLD_H_

#include <memory>
#include <string>

#include "dist/communicator.h"
#include "model/active_model.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace testing {

// The MPI world of the test program (mpi_test_main.cc), which runs under mpirun: every
// rank runs every test, and a test's collective calls must be reached by every rank in
// the same order (no ASSERT between them: a rank that left a test early would leave
// the others waiting, until CTest's timeout).
const Communicator& World();

// A temporary directory made by rank 0, its path known to every rank (collective).
class SharedTempDir {
 public:
  SharedTempDir();
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::unique_ptr<TempDir> dir_;  // rank 0
  std::string path_;
};

// The synthetic bar (tests/testing/synthetic_muscles.h) with `num_poses` poses,
// volumetric targets and a small pre-trained decoder (latent size 2, one hidden layer
// of 8, tanh, a coarse grid). Deterministic: every rank makes the same model.
ActiveModel PretrainedBar(int num_poses);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTS_DIST_MPI_WORLD_H_
