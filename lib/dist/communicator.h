#ifndef AQS_DIST_COMMUNICATOR_H_
#define AQS_DIST_COMMUNICATOR_H_

#include <string>
#include <vector>

namespace aqs {

// The processes ("ranks" 0 .. size() - 1) of a distributed run and the collective
// operations ActiveQS's distributed jobs use (training, evaluation fits). Every rank
// must call the same collectives in the same order with the same counts; rank 0, the
// root, drives the work and alone writes files. Implementations: LocalCommunicator (one
// process; every call is a copy or nothing) and the MPI world of dist/mpi_runtime.h.
//
// Sums are taken in an order that depends only on size() (not on timing), so a run
// with the same number of ranks adds the same numbers the same way. Waiting ranks
// sleep instead of spinning on the processor (see dist/mpi_runtime.h).
class Communicator {
 public:
  virtual ~Communicator() = default;

  virtual int rank() const = 0;
  virtual int size() const = 0;
  bool is_root() const { return rank() == 0; }

  // data[0, count) of rank `root` copied to every rank's data.
  virtual void Broadcast(double* data, int count, int root) const = 0;
  virtual void Broadcast(int* data, int count, int root) const = 0;
  // Rank 0's data[i] becomes the sum over ranks of data[i]; the other ranks' data is
  // left as it was.
  virtual void SumToRoot(double* data, int count) const = 0;
  // On every rank, data[i] becomes the sum (resp. the largest value, the smallest value)
  // over ranks of data[i].
  virtual void SumToAll(double* data, int count) const = 0;
  virtual void MaxToAll(double* data, int count) const = 0;
  virtual void MinToAll(int* data, int count) const = 0;
  // Rank 0 receives every rank's send[0, counts[r]) in rank order in recv (of
  // sum(counts) doubles); counts (size() entries) must be the same on every rank, and
  // send holds counts[rank()] doubles. recv is used on rank 0 only.
  virtual void GatherToRoot(const double* send, const std::vector<int>& counts,
                            double* recv) const = 0;
  // Waits until every rank has called it.
  virtual void Barrier() const = 0;
  // The implementation, for logs ("one process", "Open MPI v4.1.4, ...").
  virtual std::string Description() const = 0;

  // Helpers on top of the collectives above (collective too).

  // `text` of rank `root` on every rank.
  void BroadcastText(std::string* text, int root) const;
  // The index of the first of `items` that differs from rank 0's (an item missing on
  // one side differs), or -1 where all are the same; -1 on rank 0. Items must not hold
  // '\n'. For inputs that every rank reads from its own machine (targets, by their
  // fingerprints), which must be rank 0's. *root_count (if not null): rank 0's number of
  // items, so that a caller can tell a longer list (the index is then rank 0's count).
  int FirstItemUnlikeRoot(const std::vector<std::string>& items, int* root_count = nullptr) const;
  // Whether every rank is ok: false on every rank if one is not, with *error set on
  // every rank to the message of the lowest failing rank (prefixed "rank R: " when
  // size() > 1 and R > 0).
  bool Agree(bool ok, std::string* error) const;
};

// One process: rank 0 of 1.
class LocalCommunicator final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void Broadcast(double*, int, int) const override {}
  void Broadcast(int*, int, int) const override {}
  void SumToRoot(double*, int) const override {}
  void SumToAll(double*, int) const override {}
  void MaxToAll(double*, int) const override {}
  void MinToAll(int*, int) const override {}
  void GatherToRoot(const double* send, const std::vector<int>& counts,
                    double* recv) const override;
  void Barrier() const override {}
  std::string Description() const override { return "one process"; }
};

// The poses (or targets) of `count` that rank `rank` of `size` owns: p with
// p % size == rank, ascending. Ranks >= count own none.
std::vector<int> OwnedIndices(int count, int rank, int size);

}  // namespace aqs

#endif  // AQS_DIST_COMMUNICATOR_H_
