#include "dist/mpi_runtime.h"

#include <algorithm>
#include <cstdlib>

#if AQS_WITH_MPI
#include <time.h>

// The C API only (Open MPI's and MPICH's mpi.h otherwise declare the removed C++
// bindings, which need another library).
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace aqs {

int LauncherWorldSize() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    const char* value = std::getenv(name);
    if (value != nullptr && std::atoi(value) > 0) return std::atoi(value);
  }
  return 0;
}

#if AQS_WITH_MPI

namespace {

// Waits for a non-blocking operation: polls for 50 microseconds, then sleeps between
// polls, 20 microseconds at first, doubling up to 1 ms.
void Wait(MPI_Request* request) {
  int done = 0;
  MPI_Test(request, &done, MPI_STATUS_IGNORE);
  const double spin_until = MPI_Wtime() + 50e-6;
  while (!done && MPI_Wtime() < spin_until) MPI_Test(request, &done, MPI_STATUS_IGNORE);
  long sleep_ns = 20000;
  while (!done) {
    timespec pause = {0, sleep_ns};
    nanosleep(&pause, nullptr);
    sleep_ns = std::min(2 * sleep_ns, 1000000L);
    MPI_Test(request, &done, MPI_STATUS_IGNORE);
  }
}

// Every collective first waits, asleep, until all ranks have reached it (a
// non-blocking barrier and Wait), then runs as the blocking MPI collective: the ranks
// are then together, so it finishes at once. (A non-blocking collective only advances
// inside MPI calls, and a large one needs many: polled between sleeps, reducing 10 MB
// took 1.5 s instead of 0.01 s.)
class MpiWorld final : public Communicator {
 public:
  MpiWorld() {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  // Waits (asleep) for every rank to get here, then finalizes: MPI_Finalize itself
  // may wait by spinning, which would take a core from a rank still working (rank 0
  // writing the evaluation while the others are done).
  ~MpiWorld() override {
    Barrier();
    MPI_Finalize();
  }

  int rank() const override { return rank_; }
  int size() const override { return size_; }

  void Broadcast(double* data, int count, int root) const override {
    Barrier();
    MPI_Bcast(data, count, MPI_DOUBLE, root, MPI_COMM_WORLD);
  }
  void Broadcast(int* data, int count, int root) const override {
    Barrier();
    MPI_Bcast(data, count, MPI_INT, root, MPI_COMM_WORLD);
  }
  void SumToRoot(double* data, int count) const override {
    Barrier();
    MPI_Reduce(rank_ == 0 ? MPI_IN_PLACE : data, data, count, MPI_DOUBLE, MPI_SUM, 0,
               MPI_COMM_WORLD);
  }
  void SumToAll(double* data, int count) const override {
    Barrier();
    MPI_Allreduce(MPI_IN_PLACE, data, count, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  }
  void MaxToAll(double* data, int count) const override {
    Barrier();
    MPI_Allreduce(MPI_IN_PLACE, data, count, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  }
  void MinToAll(int* data, int count) const override {
    Barrier();
    MPI_Allreduce(MPI_IN_PLACE, data, count, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  }
  void GatherToRoot(const double* send, const std::vector<int>& counts,
                    double* recv) const override {
    std::vector<int> offsets(size_, 0);
    for (int r = 1; r < size_; ++r) offsets[r] = offsets[r - 1] + counts[r - 1];
    Barrier();
    MPI_Gatherv(send, counts[rank_], MPI_DOUBLE, recv, counts.data(), offsets.data(), MPI_DOUBLE,
                0, MPI_COMM_WORLD);
  }
  void Barrier() const override {
    MPI_Request request;
    MPI_Ibarrier(MPI_COMM_WORLD, &request);
    Wait(&request);
  }
  std::string Description() const override {
    char version[MPI_MAX_LIBRARY_VERSION_STRING];
    int length = 0;
    MPI_Get_library_version(version, &length);
    std::string text(version, length);
    const size_t end = text.find_first_of(",\n");
    return std::to_string(size_) + " MPI ranks (" + text.substr(0, end) + ")";
  }

 private:
  int rank_ = 0, size_ = 1;
};

}  // namespace

bool MpiBuilt() { return true; }

std::unique_ptr<Communicator> StartMpi(int* argc, char*** argv, std::string* error) {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) {
    *error = "MPI was started already in this process";
    return nullptr;
  }
  int provided = 0;
  if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    *error = "MPI_Init_thread failed";
    return nullptr;
  }
  // The ranks run worker threads (--threads) and call MPI from the main thread alone.
  if (provided < MPI_THREAD_FUNNELED) {
    *error = "this MPI library grants no thread support (MPI_THREAD_FUNNELED asked, level " +
             std::to_string(provided) + " given); the ranks run worker threads";
    MPI_Finalize();
    return nullptr;
  }
  return std::make_unique<MpiWorld>();
}

#else  // !AQS_WITH_MPI

bool MpiBuilt() { return false; }

std::unique_ptr<Communicator> StartMpi(int*, char***, std::string* error) {
  *error = "this ActiveQS was built without MPI: install Open MPI (Debian: libopenmpi-dev "
           "openmpi-bin; scripts/install_deps.sh does) and configure again (CMake option "
           "AQS_WITH_MPI, default AUTO: on when MPI is found)";
  return nullptr;
}

#endif  // AQS_WITH_MPI

}  // namespace aqs
