#ifndef AQS_GEOMETRY_DISJOINT_SETS_H_
#define AQS_GEOMETRY_DISJOINT_SETS_H_

// Internal: union-find used by the component searches of this module. Not part of the
// public API.

#include <numeric>
#include <utility>
#include <vector>

namespace aqs {
namespace geometry_internal {

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

}  // namespace geometry_internal
}  // namespace aqs

#endif  // AQS_GEOMETRY_DISJOINT_SETS_H_
