#include "geometry/triangle_intersections.h"

#include <glog/logging.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/triangle_tree.h"
#include "util/parallel_for.h"

namespace aqs {
namespace {

// ---- Exact orientation signs ----
//
// Error-free transformations (Knuth's TwoSum; TwoProduct through a fused multiply-add)
// turn a sum or a product of two doubles into two doubles whose sum is the exact result.
// An Expansion keeps an exact sum of many doubles as nonoverlapping terms of increasing
// magnitude, so the sign of the sum is the sign of its largest term (Shewchuk 1997).
// The floating-point filters below use Shewchuk's error bounds, which hold for the
// expressions as written (no contraction into fused multiply-adds: GCC does not contract
// in ISO C++ mode, which this project uses).

// Half the distance between 1 and the next double: the relative rounding error.
constexpr double kEpsilon = std::numeric_limits<double>::epsilon() / 2;
// |computed - exact| <= bound * permanent for the determinants below.
constexpr double kOrient2dBound = (3.0 + 16.0 * kEpsilon) * kEpsilon;
constexpr double kOrient3dBound = (7.0 + 56.0 * kEpsilon) * kEpsilon;

// a + b == *sum + *error exactly, *sum being the rounded sum.
inline void TwoSum(double a, double b, double* sum, double* error) {
  const double s = a + b;
  const double b_virtual = s - a;
  const double a_virtual = s - b_virtual;
  *error = (a - a_virtual) + (b - b_virtual);
  *sum = s;
}

// a * b == *product + *error exactly (barring underflow), *product being the rounded one.
inline void TwoProduct(double a, double b, double* product, double* error) {
  const double p = a * b;
  *error = std::fma(a, b, -p);
  *product = p;
}

// An exact sum of up to kCapacity doubles (Orient3d adds 192).
class Expansion {
 public:
  static constexpr int kCapacity = 200;

  // Adds b exactly (Shewchuk's GROW-EXPANSION, dropping zero terms).
  void Add(double b) {
    if (b == 0) return;
    DCHECK_LT(size_, kCapacity);
    double carry = b;
    int size = 0;
    for (int i = 0; i < size_; ++i) {
      double sum, error;
      TwoSum(carry, terms_[i], &sum, &error);
      if (error != 0) terms_[size++] = error;  // size <= i: terms_[i] was read already
      carry = sum;
    }
    if (carry != 0) terms_[size++] = carry;
    size_ = size;
  }

  // Adds x * y exactly (two terms).
  void AddProduct(double x, double y) {
    double product, error;
    TwoProduct(x, y, &product, &error);
    Add(error);
    Add(product);
  }

  // Adds x * y * z exactly (four terms).
  void AddProduct(double x, double y, double z) {
    if (x == 0 || y == 0 || z == 0) return;
    double xy, xy_error, product, error;
    TwoProduct(x, y, &xy, &xy_error);
    TwoProduct(xy, z, &product, &error);
    Add(error);
    Add(product);
    TwoProduct(xy_error, z, &product, &error);
    Add(error);
    Add(product);
  }

  int Sign() const {
    if (size_ == 0) return 0;
    return terms_[size_ - 1] > 0 ? 1 : -1;
  }

 private:
  double terms_[kCapacity];
  int size_ = 0;
};

// The exact difference a - b as high + low.
struct ExactDifference {
  ExactDifference(double a, double b) { TwoSum(a, -b, &part[1], &part[0]); }
  double part[2];  // part[0] + part[1]
};

int SignOf(double x) { return (x > 0) - (x < 0); }

// The sign of det[b - a, c - a] in the coordinate plane orthogonal to `axis`
// (coordinates axis + 1 and axis + 2, cyclically): the sign of component `axis` of
// (b - a) x (c - a). Positive when a, b, c turn counterclockwise seen from +axis.
int Orient2d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
             int axis) {
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  const double ui = b(i) - a(i), uj = b(j) - a(j);
  const double vi = c(i) - a(i), vj = c(j) - a(j);
  const double left = ui * vj, right = uj * vi;
  const double det = left - right;
  if (left == 0 && right == 0) return 0;  // a zero factor in both terms
  const double bound = kOrient2dBound * (std::abs(left) + std::abs(right));
  if (det > bound || -det > bound) return SignOf(det);
  const ExactDifference u[2] = {{b(i), a(i)}, {b(j), a(j)}};
  const ExactDifference v[2] = {{c(i), a(i)}, {c(j), a(j)}};
  Expansion sum;
  for (int k = 0; k < 2; ++k) {
    for (int l = 0; l < 2; ++l) {
      sum.AddProduct(u[0].part[k], v[1].part[l]);
      sum.AddProduct(-u[1].part[k], v[0].part[l]);
    }
  }
  return sum.Sign();
}

// The sign of det[b - a, c - a, d - a] = ((b - a) x (c - a)) . (d - a): positive when d
// lies on the side of the plane (a, b, c) its right-hand normal points to.
int Orient3d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
             const Eigen::Vector3d& d) {
  const Eigen::Vector3d u = b - a, v = c - a, w = d - a;
  const double yz = v(1) * w(2), zy = v(2) * w(1);
  const double zx = v(2) * w(0), xz = v(0) * w(2);
  const double xy = v(0) * w(1), yx = v(1) * w(0);
  const double det = u(0) * (yz - zy) + u(1) * (zx - xz) + u(2) * (xy - yx);
  const double permanent = std::abs(u(0)) * (std::abs(yz) + std::abs(zy)) +
                           std::abs(u(1)) * (std::abs(zx) + std::abs(xz)) +
                           std::abs(u(2)) * (std::abs(xy) + std::abs(yx));
  // A zero permanent means a zero difference in every term (a repeated point, say),
  // hence an exactly zero determinant.
  if (permanent == 0) return 0;
  const double bound = kOrient3dBound * permanent;
  if (det > bound || -det > bound) return SignOf(det);
  const ExactDifference eu[3] = {{b(0), a(0)}, {b(1), a(1)}, {b(2), a(2)}};
  const ExactDifference ev[3] = {{c(0), a(0)}, {c(1), a(1)}, {c(2), a(2)}};
  const ExactDifference ew[3] = {{d(0), a(0)}, {d(1), a(1)}, {d(2), a(2)}};
  // The six terms of the Leibniz formula: sign, then the components of u, v and w.
  static constexpr int kTerms[6][4] = {{1, 0, 1, 2},  {1, 1, 2, 0},  {1, 2, 0, 1},
                                       {-1, 0, 2, 1}, {-1, 1, 0, 2}, {-1, 2, 1, 0}};
  Expansion sum;
  for (const auto& term : kTerms) {
    for (int k = 0; k < 2; ++k) {
      for (int l = 0; l < 2; ++l) {
        for (int m = 0; m < 2; ++m) {
          sum.AddProduct(term[0] * eu[term[1]].part[k], ev[term[2]].part[l], ew[term[3]].part[m]);
        }
      }
    }
  }
  return sum.Sign();
}

// ---- Exact intersection tests between points, segments and triangles ----

// Whether a, b and c lie on one line (or coincide), exactly.
bool Collinear(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return Orient2d(a, b, c, 0) == 0 && Orient2d(a, b, c, 1) == 0 && Orient2d(a, b, c, 2) == 0;
}

// An axis along which the non-degenerate triangle (a, b, c) projects one-to-one (its
// normal has a non-zero component there).
int ProjectionAxis(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  for (int axis = 0; axis < 3; ++axis) {
    if (Orient2d(a, b, c, axis) != 0) return axis;
  }
  LOG(FATAL) << "ProjectionAxis called on a degenerate triangle";
  return 0;
}

bool LexicographicLess(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

// The collinear points a, b, c as the segment [*first, *second] they span: along a
// line the lexicographic order of the coordinates is the order along the line.
void SpannedSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                    Eigen::Vector3d* first, Eigen::Vector3d* second) {
  *first = std::min({a, b, c}, LexicographicLess);
  *second = std::max({a, b, c}, LexicographicLess);
}

// Whether r, known to be collinear with p and q in the projection along `axis`, lies in
// the bounding box of p and q there, i.e. on the projected segment [p, q].
bool InProjectedBox(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& r,
                    int axis) {
  for (int i : {(axis + 1) % 3, (axis + 2) % 3}) {
    if (r(i) < std::min(p(i), q(i)) || r(i) > std::max(p(i), q(i))) return false;
  }
  return true;
}

// Whether the projections along `axis` of the closed segments [p, q] and [r, s] meet.
// Either segment may be a point.
bool ProjectedSegmentsIntersect(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                                const Eigen::Vector3d& r, const Eigen::Vector3d& s, int axis) {
  const int pqr = Orient2d(p, q, r, axis), pqs = Orient2d(p, q, s, axis);
  const int rsp = Orient2d(r, s, p, axis), rsq = Orient2d(r, s, q, axis);
  if (pqr * pqs < 0 && rsp * rsq < 0) return true;  // a proper crossing
  // Otherwise they meet only if an endpoint of one lies on the other.
  return (pqr == 0 && InProjectedBox(p, q, r, axis)) ||
         (pqs == 0 && InProjectedBox(p, q, s, axis)) ||
         (rsp == 0 && InProjectedBox(r, s, p, axis)) || (rsq == 0 && InProjectedBox(r, s, q, axis));
}

// Whether the projection along `axis` of p lies in that of the triangle (a, b, c)
// (closed; the projected triangle non-degenerate).
bool ProjectedPointInTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                              const Eigen::Vector3d& b, const Eigen::Vector3d& c, int axis) {
  const int s0 = Orient2d(a, b, p, axis), s1 = Orient2d(b, c, p, axis);
  const int s2 = Orient2d(c, a, p, axis);
  return !((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0));
}

// Whether the closed segments [p, q] and [r, s] (either may be a point) meet in 3D:
// they must be coplanar, and then they meet exactly when their projections along all
// three axes do (at least one projection is one-to-one on the line or plane they span).
bool SegmentsIntersect(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& r,
                       const Eigen::Vector3d& s) {
  if (Orient3d(p, q, r, s) != 0) return false;
  for (int axis = 0; axis < 3; ++axis) {
    if (!ProjectedSegmentsIntersect(p, q, r, s, axis)) return false;
  }
  return true;
}

// Whether the closed segment [p, q] (possibly a point) meets the non-degenerate
// triangle (a, b, c).
bool SegmentTriangleIntersect(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                              const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& c) {
  const int sp = Orient3d(a, b, c, p), sq = Orient3d(a, b, c, q);
  if (sp * sq > 0) return false;  // both strictly on one side
  if (sp == 0 && sq == 0) {
    const int axis = ProjectionAxis(a, b, c);
    return ProjectedPointInTriangle(p, a, b, c, axis) ||
           ProjectedPointInTriangle(q, a, b, c, axis) ||
           ProjectedSegmentsIntersect(p, q, a, b, axis) ||
           ProjectedSegmentsIntersect(p, q, b, c, axis) ||
           ProjectedSegmentsIntersect(p, q, c, a, axis);
  }
  // The segment meets the plane in one point x. det[q - p, e0 - p, e1 - p] is
  // (q - p) . ((e0 - x) x (e1 - x)): the sign of the normal crossing times that of the
  // area of (x, e0, e1). x is in the triangle when no two of these areas have opposite
  // signs.
  const int s0 = Orient3d(p, q, a, b), s1 = Orient3d(p, q, b, c), s2 = Orient3d(p, q, c, a);
  return !((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0));
}

// Whether the coplanar non-degenerate triangles a and b meet, in their projection along
// `axis` (one-to-one on their plane): when no edges cross, one contains the other or
// they are apart.
bool CoplanarTrianglesIntersect(const Eigen::Vector3d* const a[3],
                                const Eigen::Vector3d* const b[3], int axis) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (ProjectedSegmentsIntersect(*a[i], *a[(i + 1) % 3], *b[j], *b[(j + 1) % 3], axis)) {
        return true;
      }
    }
  }
  return ProjectedPointInTriangle(*a[0], *b[0], *b[1], *b[2], axis) ||
         ProjectedPointInTriangle(*b[0], *a[0], *a[1], *a[2], axis);
}

// For the signs s of a triangle's vertices against a plane (not all of one strict sign,
// not all zero): a rotation r and a sign flip such that flip * s[r] >= 0 and
// flip * s[r + 1], flip * s[r + 2] <= 0, with vertex r strictly off the plane unless
// the other two both are. The triangle then meets the plane in the segment between its
// edges (r, r + 1) and (r, r + 2) (a point when flip * s[r] == 0).
void CanonicalVertex(const int s[3], int* rotation, int* flip) {
  for (int sign : {1, -1}) {
    for (int r = 0; r < 3; ++r) {
      const int s0 = sign * s[r], s1 = sign * s[(r + 1) % 3], s2 = sign * s[(r + 2) % 3];
      if (s0 >= 0 && s1 <= 0 && s2 <= 0 && (s0 > 0 || (s1 < 0 && s2 < 0))) {
        *rotation = r;
        *flip = sign;
        return;
      }
    }
  }
  LOG(FATAL) << "no canonical vertex for signs " << s[0] << " " << s[1] << " " << s[2];
}

bool AllSameStrictSign(const int s[3]) {
  return (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0);
}

// The query of one triangle's box against a tree: calls visit(t) for every triangle t
// of the tree whose box touches `box`.
template <typename Visit>
void QueryBox(const geometry_internal::TriangleTree& tree,
              const std::vector<Eigen::AlignedBox3d>& boxes, const Eigen::AlignedBox3d& box,
              const Visit& visit) {
  if (tree.nodes.empty()) return;
  // Depth is O(log M); 128 entries cover any tree the median split makes.
  int stack[128];
  int size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const geometry_internal::TriangleTreeNode& node = tree.nodes[stack[--size]];
    if (!node.box.intersects(box)) continue;
    if (node.is_leaf()) {
      for (int i = node.begin; i < node.end; ++i) {
        const int t = tree.order[i];
        if (boxes[t].intersects(box)) visit(t);
      }
    } else {
      CHECK_LE(size + 2, 128);
      stack[size++] = node.right;
      stack[size++] = node.left;
    }
  }
}

std::vector<Eigen::AlignedBox3d> TriangleBoxes(const Eigen::Matrix3Xd& vertices,
                                               const Eigen::Matrix3Xi& triangles) {
  const int num_vertices = static_cast<int>(vertices.cols());
  std::vector<Eigen::AlignedBox3d> boxes(triangles.cols());
  for (int t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int v = triangles(k, t);
      CHECK(v >= 0 && v < num_vertices) << "triangle " << t << " has vertex index " << v
                                        << " out of range [0, " << num_vertices << ")";
      boxes[t].extend(vertices.col(v));
    }
  }
  return boxes;
}

// Leaves of up to 4 triangles, as in TriangleBvh.
constexpr int kLeafSize = 4;
// Triangles per work chunk handed to a thread.
constexpr int kGrain = 64;

// Concatenates per-thread pair lists and sorts them.
int MergePairs(std::vector<std::vector<std::pair<int, int>>>* per_thread,
               std::vector<std::pair<int, int>>* pairs) {
  size_t count = 0;
  for (const auto& list : *per_thread) count += list.size();
  if (pairs != nullptr) {
    pairs->clear();
    pairs->reserve(count);
    for (const auto& list : *per_thread) pairs->insert(pairs->end(), list.begin(), list.end());
    std::sort(pairs->begin(), pairs->end());
  }
  return static_cast<int>(count);
}

}  // namespace

bool TrianglesIntersect(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1,
                        const Eigen::Vector3d& a2, const Eigen::Vector3d& b0,
                        const Eigen::Vector3d& b1, const Eigen::Vector3d& b2) {
  const bool a_flat = Collinear(a0, a1, a2);
  const bool b_flat = Collinear(b0, b1, b2);
  if (a_flat || b_flat) {
    Eigen::Vector3d a_first, a_second, b_first, b_second;
    if (a_flat) SpannedSegment(a0, a1, a2, &a_first, &a_second);
    if (b_flat) SpannedSegment(b0, b1, b2, &b_first, &b_second);
    if (a_flat && b_flat) return SegmentsIntersect(a_first, a_second, b_first, b_second);
    if (a_flat) return SegmentTriangleIntersect(a_first, a_second, b0, b1, b2);
    return SegmentTriangleIntersect(b_first, b_second, a0, a1, a2);
  }

  const Eigen::Vector3d* a[3] = {&a0, &a1, &a2};
  const Eigen::Vector3d* b[3] = {&b0, &b1, &b2};
  // The sides of b's vertices against a's plane, and of a's against b's.
  const int b_sides[3] = {Orient3d(a0, a1, a2, b0), Orient3d(a0, a1, a2, b1),
                          Orient3d(a0, a1, a2, b2)};
  if (AllSameStrictSign(b_sides)) return false;
  const int a_sides[3] = {Orient3d(b0, b1, b2, a0), Orient3d(b0, b1, b2, a1),
                          Orient3d(b0, b1, b2, a2)};
  if (AllSameStrictSign(a_sides)) return false;
  if ((b_sides[0] == 0 && b_sides[1] == 0 && b_sides[2] == 0) ||
      (a_sides[0] == 0 && a_sides[1] == 0 && a_sides[2] == 0)) {
    return CoplanarTrianglesIntersect(a, b, ProjectionAxis(a0, a1, a2));
  }

  // The planes cross in a line L. Rotate each triangle so that its first vertex p1
  // (q1) is alone on its side of the other's plane (or alone on the plane), and reverse
  // the other triangle if needed so that this side is the positive one. Then a meets L
  // in a segment from edge (p1, p3) to edge (p1, p2), and b in one from edge (q1, q2)
  // to edge (q1, q3), both in the direction n_a x n_b; they overlap exactly when
  // det[p2 - p1, q1 - p1, q2 - p1] <= 0 and det[p3 - p1, q1 - p1, q3 - p1] >= 0 (each
  // determinant has the sign of the gap between the two points of L in question).
  int a_rotation, a_flip, b_rotation, b_flip;
  CanonicalVertex(a_sides, &a_rotation, &a_flip);
  CanonicalVertex(b_sides, &b_rotation, &b_flip);
  const Eigen::Vector3d* p1 = a[a_rotation];
  const Eigen::Vector3d* p2 = a[(a_rotation + 1) % 3];
  const Eigen::Vector3d* p3 = a[(a_rotation + 2) % 3];
  const Eigen::Vector3d* q1 = b[b_rotation];
  const Eigen::Vector3d* q2 = b[(b_rotation + 1) % 3];
  const Eigen::Vector3d* q3 = b[(b_rotation + 2) % 3];
  if (b_flip < 0) std::swap(p2, p3);  // reversing a flips the sides of b's vertices
  if (a_flip < 0) std::swap(q2, q3);
  return Orient3d(*p1, *p2, *q1, *q2) <= 0 && Orient3d(*p1, *p3, *q1, *q3) >= 0;
}

int FindIntersectingTrianglePairs(const Eigen::Matrix3Xd& vertices,
                                  const Eigen::Matrix3Xi& triangles,
                                  const TriangleIntersectionOptions& options,
                                  std::vector<std::pair<int, int>>* pairs) {
  const int num_triangles = static_cast<int>(triangles.cols());
  const std::vector<Eigen::AlignedBox3d> boxes = TriangleBoxes(vertices, triangles);
  const geometry_internal::TriangleTree tree =
      geometry_internal::BuildTriangleTree(vertices, triangles, kLeafSize);
  std::vector<std::vector<std::pair<int, int>>> per_thread(
      ParallelForThreadCount(options.num_threads, num_triangles, kGrain));
  ParallelFor(
      options.num_threads, 0, num_triangles,
      [&](int thread_id, int i) {
        const Eigen::Vector3i ti = triangles.col(i);
        QueryBox(tree, boxes, boxes[i], [&](int j) {
          if (j <= i) return;
          const Eigen::Vector3i tj = triangles.col(j);
          if (options.skip_adjacent) {
            for (int k = 0; k < 3; ++k) {
              if (tj(k) == ti(0) || tj(k) == ti(1) || tj(k) == ti(2)) return;
            }
          }
          if (TrianglesIntersect(vertices.col(ti(0)), vertices.col(ti(1)), vertices.col(ti(2)),
                                 vertices.col(tj(0)), vertices.col(tj(1)), vertices.col(tj(2)))) {
            per_thread[thread_id].emplace_back(i, j);
          }
        });
      },
      kGrain);
  return MergePairs(&per_thread, pairs);
}

int FindIntersectingTrianglePairs(const Eigen::Matrix3Xd& vertices_a,
                                  const Eigen::Matrix3Xi& triangles_a,
                                  const Eigen::Matrix3Xd& vertices_b,
                                  const Eigen::Matrix3Xi& triangles_b, int num_threads,
                                  std::vector<std::pair<int, int>>* pairs) {
  const int num_triangles_a = static_cast<int>(triangles_a.cols());
  const std::vector<Eigen::AlignedBox3d> boxes_a = TriangleBoxes(vertices_a, triangles_a);
  const std::vector<Eigen::AlignedBox3d> boxes_b = TriangleBoxes(vertices_b, triangles_b);
  const geometry_internal::TriangleTree tree =
      geometry_internal::BuildTriangleTree(vertices_b, triangles_b, kLeafSize);
  std::vector<std::vector<std::pair<int, int>>> per_thread(
      ParallelForThreadCount(num_threads, num_triangles_a, kGrain));
  ParallelFor(
      num_threads, 0, num_triangles_a,
      [&](int thread_id, int i) {
        const Eigen::Vector3i ti = triangles_a.col(i);
        QueryBox(tree, boxes_b, boxes_a[i], [&](int j) {
          const Eigen::Vector3i tj = triangles_b.col(j);
          if (TrianglesIntersect(vertices_a.col(ti(0)), vertices_a.col(ti(1)),
                                 vertices_a.col(ti(2)), vertices_b.col(tj(0)),
                                 vertices_b.col(tj(1)), vertices_b.col(tj(2)))) {
            per_thread[thread_id].emplace_back(i, j);
          }
        });
      },
      kGrain);
  return MergePairs(&per_thread, pairs);
}

}  // namespace aqs
