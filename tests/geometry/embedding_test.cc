#include "geometry/embedding.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "mesh/lattice.h"
#include "testing/test_meshes.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

TetMesh Lattice(LatticeType type, int n, double spacing) {
  LatticeOptions options;
  options.type = type;
  options.nx = n;
  options.ny = n + 1;
  options.nz = n + 2;
  options.spacing = spacing;
  options.origin = Eigen::Vector3d(-0.3, 0.7, 1.1);
  return MakeLatticeMesh(options);
}

void ExpectReproduces(const TetMesh& mesh, const Embedding& embedding,
                      const Eigen::Matrix3Xd& points) {
  const Eigen::Matrix3Xd positions = EmbeddedPositions(embedding, mesh.tets, mesh.vertices);
  ASSERT_EQ(positions.cols(), points.cols());
  EXPECT_LT((positions - points).cwiseAbs().maxCoeff(), 1e-12);
  for (int i = 0; i < embedding.num_points(); ++i) {
    EXPECT_NEAR(embedding.weights.col(i).sum(), 1.0, 1e-12);
  }
}

TEST(EmbeddingTest, SingleTetInsideBoundaryAndOutside) {
  const TetMesh mesh = testing::UnitTet();
  Eigen::Matrix3Xd points(3, 6);
  points << 0.1, 0, 1, 0.5, -1, 1,  //
      0.2, 0, 0, 0.5, 0.2, 1,       //
      0.3, 0, 0, 0, 0.2, 1;
  // inside, vertex 0, vertex 1, middle of an edge, outside (face x = 0 at distance 1),
  // outside (closest to the face x + y + z = 1: distance 2 / sqrt(3)).
  const Embedding embedding = EmbedPoints(mesh, points, 1);
  ASSERT_EQ(embedding.num_points(), 6);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(embedding.element[i], 0);
    EXPECT_EQ(embedding.outside_distance[i], 0.0) << "point " << i;
  }
  EXPECT_LT((embedding.weights.col(0) - Eigen::Vector4d(0.4, 0.1, 0.2, 0.3)).norm(), 1e-15);
  EXPECT_NEAR(embedding.outside_distance[4], 1.0, 1e-15);
  EXPECT_NEAR(embedding.outside_distance[5], 2.0 / std::sqrt(3.0), 1e-15);
  // Outside points hang on the closest surface point: non-negative weights, an offset
  // as long as the distance.
  for (int i : {4, 5}) {
    EXPECT_GE(embedding.weights.col(i).minCoeff(), 0.0);
    EXPECT_NEAR(embedding.offsets.col(i).norm(), embedding.outside_distance[i], 1e-15);
  }
  for (int i = 0; i < 4; ++i) EXPECT_EQ(embedding.offsets.col(i).norm(), 0.0);
  ExpectReproduces(mesh, embedding, points);
}

TEST(EmbeddingTest, LatticePointsAreFoundDeterministically) {
  for (LatticeType type : {LatticeType::kKuhn, LatticeType::kBcc}) {
    const TetMesh mesh = Lattice(type, 4, 0.5);
    // Random points in the box, every lattice vertex (on many elements), and element
    // face midpoints.
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    const Eigen::Vector3d lo(-0.3, 0.7, 1.1), size(2.0, 2.5, 3.0);
    const int num_random = 500;
    Eigen::Matrix3Xd points(3, num_random + mesh.num_vertices() + mesh.num_tets());
    for (int i = 0; i < num_random; ++i) {
      points.col(i) = lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(size);
    }
    points.middleCols(num_random, mesh.num_vertices()) = mesh.vertices;
    for (int t = 0; t < mesh.num_tets(); ++t) {
      points.col(num_random + mesh.num_vertices() + t) =
          (mesh.vertices.col(mesh.tets(0, t)) + mesh.vertices.col(mesh.tets(1, t)) +
           mesh.vertices.col(mesh.tets(2, t))) /
          3.0;
    }
    const Embedding one = EmbedPoints(mesh, points, 1);
    const Embedding two = EmbedPoints(mesh, points, 2);
    EXPECT_EQ(one.element, two.element);
    EXPECT_EQ(one.weights, two.weights);
    for (int i = 0; i < points.cols(); ++i) {
      ASSERT_EQ(one.outside_distance[i], 0.0) << "point " << i;
      EXPECT_GE(one.weights.col(i).minCoeff(), -kEmbeddingTolerance);
    }
    ExpectReproduces(mesh, one, points);

    // An affine deformation is interpolated exactly.
    Eigen::Matrix3d a;
    a << 1.1, 0.2, -0.1, 0.05, 0.9, 0.3, -0.2, 0.1, 1.3;
    const Eigen::Vector3d b(0.5, -2, 3);
    const Eigen::Matrix3Xd deformed = (a * mesh.vertices).colwise() + b;
    const Eigen::Matrix3Xd expected = (a * points).colwise() + b;
    EXPECT_LT((EmbeddedPositions(one, mesh.tets, deformed) - expected).cwiseAbs().maxCoeff(),
              1e-12);
  }
}

TEST(EmbeddingTest, OutsidePointsGetTheDistanceToTheMesh) {
  const TetMesh mesh = Lattice(LatticeType::kBcc, 3, 1.0);  // box [-0.3,2.7]x[0.7,4.7]x[1.1,6.1]
  Eigen::Matrix3Xd points(3, 3);
  points << -1.3, 1.0, 3.7,  //
      1.0, 2.0, 5.7,         //
      2.0, 0.1, 7.1;
  const Embedding embedding = EmbedPoints(mesh, points, 2);
  EXPECT_NEAR(embedding.outside_distance[0], 1.0, 1e-12);
  EXPECT_NEAR(embedding.outside_distance[1], 1.0, 1e-12);
  EXPECT_NEAR(embedding.outside_distance[2], std::sqrt(3.0), 1e-12);
  for (int i = 0; i < 3; ++i) {
    const int t = embedding.element[i];
    ASSERT_GE(t, 0);
    EXPECT_GE(embedding.weights.col(i).minCoeff(), 0.0);
    EXPECT_NEAR(embedding.offsets.col(i).norm(), embedding.outside_distance[i], 1e-12);
  }
  ExpectReproduces(mesh, embedding, points);
  // No leverage: a translated mesh carries outside points along; a point far outside
  // moves like the surface point it hangs on, not amplified by its distance.
  const Eigen::Vector3d shift(0.3, -0.2, 0.5);
  const Eigen::Matrix3Xd moved = mesh.vertices.colwise() + shift;
  EXPECT_LT(((EmbeddedPositions(embedding, mesh.tets, moved) - points).colwise() - shift)
                .cwiseAbs()
                .maxCoeff(),
            1e-12);
  Eigen::Matrix3Xd far(3, 1);
  far << 1.0, 2.0, 40.0;  // 33.9 beyond the top face
  const Embedding far_embedding = EmbedPoints(mesh, far, 1);
  Eigen::Matrix3Xd stretched = mesh.vertices;
  stretched.row(0) *= 1.1;  // a 10% stretch along x
  const double motion = (EmbeddedPositions(far_embedding, mesh.tets, stretched) - far).norm();
  EXPECT_LT(motion, 0.1 * 2.7 + 1e-12);
}

// Points inside and outside a small lattice (those outside have offsets) and a
// random deformed state of it.
struct OperatorFixture {
  TetMesh mesh = Lattice(LatticeType::kKuhn, 2, 0.5);  // box [-0.3,0.7]x[0.7,2.2]x[1.1,3.1]
  Embedding embedding;
  Eigen::Matrix3Xd x;
  int num_outside = 0;

  OperatorFixture() {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    Eigen::Matrix3Xd points(3, 40);
    for (int i = 0; i < points.cols(); ++i) {
      points.col(i) = Eigen::Vector3d(0.2 + 1.4 * u(rng), 1.45 + 2.0 * u(rng), 2.1 + 2.4 * u(rng));
    }
    embedding = EmbedPoints(mesh, points, 1);
    for (int i = 0; i < embedding.num_points(); ++i) num_outside += embedding.outside_distance[i] > 0;
    x = mesh.vertices;
    for (int i = 0; i < x.size(); ++i) x.data()[i] += 0.2 * u(rng);
  }
};

TEST(EmbeddingOperatorTest, StencilsAreTheRowsOfApplyBitwise) {
  const OperatorFixture f;
  ASSERT_GT(f.num_outside, 0);
  ASSERT_LT(f.num_outside, f.embedding.num_points());
  const Eigen::Matrix3Xd positions = EmbeddedPositions(f.embedding, f.mesh.tets, f.x);
  const std::vector<PointStencil> stencils = EmbeddingStencils(f.embedding, f.mesh.tets);
  ASSERT_EQ(static_cast<int>(stencils.size()), f.embedding.num_points());
  for (int i = 0; i < f.embedding.num_points(); ++i) {
    const PointStencil s = EmbeddingStencil(f.embedding, f.mesh.tets, i);
    Eigen::Vector3d expected = f.embedding.offsets.col(i);
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(s.vertex[k], f.mesh.tets(k, f.embedding.element[i]));
      EXPECT_EQ(s.weight[k], f.embedding.weights(k, i));
      EXPECT_EQ(stencils[i].vertex[k], s.vertex[k]);
      EXPECT_EQ(stencils[i].weight[k], s.weight[k]);
      expected += s.weight[k] * f.x.col(s.vertex[k]);
    }
    EXPECT_EQ(s.offset, f.embedding.offsets.col(i));
    EXPECT_EQ(s.Position(f.x), positions.col(i));  // the same sums, bitwise
    EXPECT_LT((positions.col(i) - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
  // The offsets are the affine part: Apply(0) = offsets.
  EXPECT_EQ(EmbeddedPositions(f.embedding, f.mesh.tets,
                              Eigen::Matrix3Xd::Zero(3, f.mesh.num_vertices())),
            f.embedding.offsets);
}

TEST(EmbeddingOperatorTest, TransposeIsTheAdjointOfTheLinearPart) {
  const OperatorFixture f;
  const int nv = f.mesh.num_vertices();
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Matrix3Xd g(3, f.embedding.num_points());
  for (int i = 0; i < g.size(); ++i) g.data()[i] = normal(rng);
  // <A x, g> = <x, A^T g>, A x = Apply(x) - offsets.
  const Eigen::Matrix3Xd ax = EmbeddedPositions(f.embedding, f.mesh.tets, f.x) - f.embedding.offsets;
  const Eigen::Matrix3Xd atg = EmbeddingTranspose(f.embedding, f.mesh.tets, g, nv);
  ASSERT_EQ(atg.cols(), nv);
  const double left = (ax.array() * g.array()).sum();
  const double right = (f.x.array() * atg.array()).sum();
  EXPECT_NEAR(left, right, 1e-12 * (std::abs(left) + 1.0));
  // As a gradient: L(x) = 1/2 |P(x) - y|^2 has dL/dx = A^T (P(x) - y); central
  // differences of L (quadratic: exact up to round-off).
  const Eigen::Matrix3Xd y = f.embedding.offsets + g;
  auto loss = [&](const Eigen::Matrix3Xd& state) {
    return 0.5 * (EmbeddedPositions(f.embedding, f.mesh.tets, state) - y).squaredNorm();
  };
  const Eigen::Matrix3Xd gradient = EmbeddingTranspose(
      f.embedding, f.mesh.tets, EmbeddedPositions(f.embedding, f.mesh.tets, f.x) - y, nv);
  const double h = 1e-5;
  double max_error = 0.0;
  for (int i = 0; i < f.x.size(); ++i) {
    Eigen::Matrix3Xd plus = f.x, minus = f.x;
    plus.data()[i] += h;
    minus.data()[i] -= h;
    max_error = std::max(max_error, std::abs((loss(plus) - loss(minus)) / (2 * h) - gradient.data()[i]));
  }
  EXPECT_LT(max_error, 1e-7 * (gradient.cwiseAbs().maxCoeff() + 1.0));
  // Vertices no point uses get nothing.
  std::vector<bool> used(nv, false);
  for (int i = 0; i < f.embedding.num_points(); ++i) {
    for (int k = 0; k < 4; ++k) used[f.mesh.tets(k, f.embedding.element[i])] = true;
  }
  for (int v = 0; v < nv; ++v) {
    if (!used[v]) {
      EXPECT_EQ(atg.col(v), Eigen::Vector3d::Zero()) << "vertex " << v;
    }
  }
}

TEST(EmbeddingTest, LargeLatticeIsFast) {
  // About 250K elements and 13K points, the size of the face meshes.
  const TetMesh mesh = Lattice(LatticeType::kBcc, 26, 0.5);
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::Matrix3Xd points(3, 13294);
  const Eigen::Vector3d lo(-0.3, 0.7, 1.1), size(13, 13.5, 14);
  for (int i = 0; i < points.cols(); ++i) {
    points.col(i) = lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(size);
  }
  WallTimer timer;
  const Embedding embedding = EmbedPoints(mesh, points, 2);
  std::printf("EmbedPoints: %d points in %d elements: %.3f s\n", static_cast<int>(points.cols()),
              mesh.num_tets(), timer.Seconds());
  for (int i = 0; i < points.cols(); ++i) ASSERT_EQ(embedding.outside_distance[i], 0.0);
  ExpectReproduces(mesh, embedding, points);
}

}  // namespace
}  // namespace aqs
