#include "geometry/embedding.h"

#include <glog/logging.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/triangle_bvh.h"
#include "mesh/boundary_surface.h"
#include "util/parallel_for.h"

namespace aqs {
namespace {

// An element is flat (contains nothing) if |det Dm| <= kFlat * (longest edge)^3.
constexpr double kFlat = 1e-12;

// Element bounding boxes are grown by this fraction of their largest extent before they
// are entered in the grid, so that points on an element's boundary whose coordinates
// are rounded just outside its box still find it.
constexpr double kBoxPadding = 1e-9;

// At most this many grid cells per element.
constexpr double kMaxCellsPerElement = 4.0;

void ElementCorners(const TetMesh& mesh, int t, Eigen::Vector3d x[4]) {
  for (int k = 0; k < 4; ++k) x[k] = mesh.vertices.col(mesh.tets(k, t));
}

// Barycentric coordinates of p with respect to the corners x[0..3]. Returns false
// (weights untouched) for a flat element.
bool Barycentric(const Eigen::Vector3d x[4], const Eigen::Vector3d& p, Eigen::Vector4d* weights) {
  Eigen::Matrix3d dm;
  dm.col(0) = x[1] - x[0];
  dm.col(1) = x[2] - x[0];
  dm.col(2) = x[3] - x[0];
  double longest_squared = dm.colwise().squaredNorm().maxCoeff();
  longest_squared = std::max({longest_squared, (x[2] - x[1]).squaredNorm(),
                              (x[3] - x[1]).squaredNorm(), (x[3] - x[2]).squaredNorm()});
  const double determinant = dm.determinant();
  if (!(std::abs(determinant) > kFlat * longest_squared * std::sqrt(longest_squared))) {
    return false;
  }
  const Eigen::Vector3d l = dm.inverse() * (p - x[0]);
  *weights << 1.0 - l.sum(), l;
  return true;
}

// Uniform grid over the elements' bounding boxes; cell c = i + n0 (j + n1 k) lists the
// elements whose (padded) boxes overlap it, in increasing order, in
// elements[offsets[c] .. offsets[c + 1]).
struct ElementGrid {
  Eigen::Vector3d origin;
  double cell = 1;
  Eigen::Vector3i n;
  std::vector<int> offsets;
  std::vector<int> elements;

  // The cell index along each axis of p, clamped to the grid.
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor((p(a) - origin(a)) / cell);
      c(a) = static_cast<int>(std::clamp(f, 0.0, static_cast<double>(n(a) - 1)));
    }
    return c;
  }
  int Index(const Eigen::Vector3i& c) const { return c(0) + n(0) * (c(1) + n(1) * c(2)); }
};

ElementGrid BuildElementGrid(const TetMesh& mesh) {
  const int num_tets = mesh.num_tets();
  std::vector<Eigen::AlignedBox3d> boxes(num_tets);
  Eigen::AlignedBox3d all;
  double mean_extent = 0;
  for (int t = 0; t < num_tets; ++t) {
    Eigen::Vector3d x[4];
    ElementCorners(mesh, t, x);
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 4; ++k) box.extend(x[k]);
    const double extent = box.sizes().maxCoeff();
    mean_extent += extent / num_tets;
    const Eigen::Vector3d pad = Eigen::Vector3d::Constant(kBoxPadding * extent);
    box.min() -= pad;
    box.max() += pad;
    boxes[t] = box;
    all.extend(box);
  }
  ElementGrid grid;
  grid.origin = all.min();
  const Eigen::Vector3d sizes = all.sizes();
  double cell = mean_extent > 0 ? mean_extent : std::max(sizes.maxCoeff(), 1.0);
  const double max_cells = kMaxCellsPerElement * num_tets + 8;
  auto count = [&sizes](double h, int a) { return std::max(1.0, std::ceil(sizes(a) / h)); };
  while (count(cell, 0) * count(cell, 1) * count(cell, 2) > max_cells) cell *= 1.25;
  grid.cell = cell;
  for (int a = 0; a < 3; ++a) grid.n(a) = static_cast<int>(count(cell, a));
  const int num_cells = grid.n.prod();

  // Counting pass, then fill in element order (each cell's list comes out sorted).
  grid.offsets.assign(num_cells + 1, 0);
  auto for_each_cell = [&grid](const Eigen::AlignedBox3d& box, auto&& visit) {
    const Eigen::Vector3i lo = grid.Cell(box.min());
    const Eigen::Vector3i hi = grid.Cell(box.max());
    for (int k = lo(2); k <= hi(2); ++k) {
      for (int j = lo(1); j <= hi(1); ++j) {
        for (int i = lo(0); i <= hi(0); ++i) visit(grid.Index(Eigen::Vector3i(i, j, k)));
      }
    }
  };
  for (int t = 0; t < num_tets; ++t) {
    for_each_cell(boxes[t], [&grid](int c) { ++grid.offsets[c + 1]; });
  }
  for (int c = 0; c < num_cells; ++c) grid.offsets[c + 1] += grid.offsets[c];
  grid.elements.resize(grid.offsets[num_cells]);
  std::vector<int> cursor(grid.offsets.begin(), grid.offsets.end() - 1);
  for (int t = 0; t < num_tets; ++t) {
    for_each_cell(boxes[t], [&](int c) { grid.elements[cursor[c]++] = t; });
  }
  return grid;
}

}  // namespace

Embedding EmbedPoints(const TetMesh& mesh, const Eigen::Matrix3Xd& points, int num_threads) {
  const int num_tets = mesh.num_tets();
  const int num_points = static_cast<int>(points.cols());
  CHECK_GT(num_tets, 0) << "cannot embed points in a mesh without elements";
  for (int t = 0; t < num_tets; ++t) {
    for (int k = 0; k < 4; ++k) {
      CHECK(mesh.tets(k, t) >= 0 && mesh.tets(k, t) < mesh.num_vertices())
          << "element " << t << " has vertex index " << mesh.tets(k, t) << " out of range";
    }
  }
  CHECK(points.allFinite()) << "points to embed must be finite";

  Embedding embedding;
  embedding.element.assign(num_points, -1);
  embedding.weights.setZero(4, num_points);
  embedding.offsets.setZero(3, num_points);
  embedding.outside_distance.assign(num_points, 0.0);
  if (num_points == 0) return embedding;

  const ElementGrid grid = BuildElementGrid(mesh);
  ParallelFor(
      num_threads, 0, num_points,
      [&](int, int i) {
        const Eigen::Vector3d p = points.col(i);
        const int c = grid.Index(grid.Cell(p));
        double best = -std::numeric_limits<double>::infinity();
        for (int e = grid.offsets[c]; e < grid.offsets[c + 1]; ++e) {
          const int t = grid.elements[e];
          Eigen::Vector3d x[4];
          ElementCorners(mesh, t, x);
          Eigen::Vector4d w;
          if (!Barycentric(x, p, &w)) continue;
          const double depth = w.minCoeff();
          if (depth >= -kEmbeddingTolerance && depth > best) {
            best = depth;
            embedding.element[i] = t;
            embedding.weights.col(i) = w;
          }
        }
      },
      64);

  // Points in no element: the closest boundary triangle names the closest element.
  std::vector<int> outside;
  for (int i = 0; i < num_points; ++i) {
    if (embedding.element[i] < 0) outside.push_back(i);
  }
  if (outside.empty()) return embedding;
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);
  const TriangleBvh bvh(mesh.vertices, boundary.triangles);
  ParallelFor(
      num_threads, 0, static_cast<int>(outside.size()),
      [&](int, int j) {
        const int i = outside[j];
        const Eigen::Vector3d p = points.col(i);
        const ClosestPointResult closest = bvh.ClosestPoint(p);
        CHECK_GE(closest.triangle, 0);
        const int t = boundary.triangle_tet[closest.triangle];
        embedding.element[i] = t;
        embedding.outside_distance[i] = closest.distance;
        // The closest point's weights on the element's boundary face, and the offset.
        Eigen::Vector4d face_weights = Eigen::Vector4d::Zero();
        for (int k = 0; k < 3; ++k) {
          const int v = boundary.triangles(k, closest.triangle);
          for (int m = 0; m < 4; ++m) {
            if (mesh.tets(m, t) == v) face_weights(m) += closest.barycentric(k);
          }
        }
        embedding.weights.col(i) = face_weights;
        embedding.offsets.col(i) = p - closest.point;
      },
      16);
  return embedding;
}

PointStencil EmbeddingStencil(const Embedding& embedding, const Eigen::Matrix4Xi& tets, int i) {
  CHECK(i >= 0 && i < embedding.num_points()) << "point " << i;
  const int t = embedding.element[i];
  CHECK(t >= 0 && t < tets.cols())
      << "point " << i << " has element " << t << " out of range [0, " << tets.cols() << ")";
  PointStencil stencil;
  for (int k = 0; k < 4; ++k) {
    stencil.vertex[k] = tets(k, t);
    stencil.weight[k] = embedding.weights(k, i);
  }
  stencil.offset = embedding.offsets.col(i);
  return stencil;
}

std::vector<PointStencil> EmbeddingStencils(const Embedding& embedding, const Eigen::Matrix4Xi& tets) {
  std::vector<PointStencil> stencils(embedding.num_points());
  for (int i = 0; i < embedding.num_points(); ++i) stencils[i] = EmbeddingStencil(embedding, tets, i);
  return stencils;
}

namespace {

// CHECKs that the vertices of a stencil index a state of num_vertices columns.
void CheckStencilVertices(const PointStencil& stencil, int num_vertices) {
  for (int k = 0; k < 4; ++k) {
    CHECK(stencil.vertex[k] >= 0 && stencil.vertex[k] < num_vertices)
        << "an embedding element has vertex " << stencil.vertex[k] << ", but the state has "
        << num_vertices << " vertices";
  }
}

}  // namespace

Eigen::Matrix3Xd EmbeddedPositions(const Embedding& embedding, const Eigen::Matrix4Xi& tets,
                                   const Eigen::Matrix3Xd& x) {
  const int num_points = embedding.num_points();
  CHECK_EQ(embedding.weights.cols(), num_points);
  CHECK_EQ(embedding.offsets.cols(), num_points);
  Eigen::Matrix3Xd positions(3, num_points);
  for (int i = 0; i < num_points; ++i) {
    const PointStencil stencil = EmbeddingStencil(embedding, tets, i);
    CheckStencilVertices(stencil, static_cast<int>(x.cols()));
    positions.col(i) = stencil.Position(x);
  }
  return positions;
}

Eigen::Matrix3Xd EmbeddingTranspose(const Embedding& embedding, const Eigen::Matrix4Xi& tets,
                                    const Eigen::Matrix3Xd& g, int num_vertices) {
  const int num_points = embedding.num_points();
  CHECK_EQ(embedding.weights.cols(), num_points);
  CHECK_EQ(g.cols(), num_points) << "the per-point field has the wrong number of columns";
  Eigen::Matrix3Xd result = Eigen::Matrix3Xd::Zero(3, num_vertices);
  for (int i = 0; i < num_points; ++i) {
    const PointStencil stencil = EmbeddingStencil(embedding, tets, i);
    CheckStencilVertices(stencil, num_vertices);
    for (int k = 0; k < 4; ++k) result.col(stencil.vertex[k]) += stencil.weight[k] * g.col(i);
  }
  return result;
}

}  // namespace aqs
