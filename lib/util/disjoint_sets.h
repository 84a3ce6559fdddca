#ifndef AQS_UTIL_DISJOINT_SETS_H_
#define AQS_UTIL_DISJOINT_SETS_H_

// Union-find for the component searches (geometry's surface and lattice components,
// mesh's pieces).

#include <numeric>
#include <utility>
#include <vector>

namespace aqs {

// Disjoint sets over [0, size) with path halving. Union makes the smaller of the two
// roots the representative, so the representative of every set is its smallest element.
class DisjointSets {
 public:
  explicit DisjointSets(int size) : parent_(size) { std::iota(parent_.begin(), parent_.end(), 0); }

  // The representative of x's set.
  int Find(int x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }

  // Merges the sets of a and b.
  void Union(int a, int b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent_[a] = b;
  }

 private:
  std::vector<int> parent_;
};

}  // namespace aqs

#endif  // AQS_UTIL_DISJOINT_SETS_H_
