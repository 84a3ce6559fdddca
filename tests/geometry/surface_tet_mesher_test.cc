#include "geometry/surface_tet_mesher.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"
#include "mesh/tet_mesh.h"
#include "testing/source_data.h"
#include "testing/test_surfaces.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

::testing::AssertionResult Contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\"" << text << "\" does not contain \"" << part << "\"";
}

// The number of face-connected components of `mesh` (computed independently of the mesher).
int CountFaceComponents(const TetMesh& mesh) {
  std::map<std::array<int, 3>, std::vector<int>> faces;
  for (int t = 0; t < mesh.num_tets(); ++t) {
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> face;
      for (int k = 0; k < 3; ++k) face[k] = mesh.tets((f + 1 + k) % 4, t);
      std::sort(face.begin(), face.end());
      faces[face].push_back(t);
    }
  }
  std::vector<int> parent(mesh.num_tets());
  for (int t = 0; t < mesh.num_tets(); ++t) parent[t] = t;
  std::function<int(int)> find = [&](int x) {
    return parent[x] == x ? x : parent[x] = find(parent[x]);
  };
  for (const auto& [face, tets] : faces) {
    for (size_t i = 1; i < tets.size(); ++i) parent[find(tets[i])] = find(tets[0]);
  }
  int count = 0;
  for (int t = 0; t < mesh.num_tets(); ++t) count += find(t) == t;
  return count;
}

double MeshVolume(const TetMesh& mesh) {
  double volume = 0;
  for (int t = 0; t < mesh.num_tets(); ++t) volume += SignedTetVolume(mesh, mesh.vertices, t);
  return volume;
}

// The mesh is valid, every element positive, every vertex used, and every surface vertex
// inside an element.
void ExpectValidAndEmbedding(const TetMesh& mesh, const Eigen::Matrix3Xd& surface_vertices) {
  std::string error;
  EXPECT_TRUE(ValidateTetMesh(mesh, "mesh", &error)) << error;
  std::vector<char> used(mesh.num_vertices(), 0);
  for (int t = 0; t < mesh.num_tets(); ++t) {
    EXPECT_GT(SignedTetVolume(mesh, mesh.vertices, t), 0) << "element " << t;
    for (int k = 0; k < 4; ++k) used[mesh.tets(k, t)] = 1;
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) EXPECT_TRUE(used[v]) << "vertex " << v;
  const Embedding embedding = EmbedPoints(mesh, surface_vertices, 2);
  for (int i = 0; i < embedding.num_points(); ++i) {
    ASSERT_EQ(embedding.outside_distance[i], 0.0) << "surface vertex " << i;
  }
}

TEST(SurfaceTetMesherTest, ClosedSphereVolume) {
  const double radius = 5;
  const SurfaceMesh sphere = testing::Icosphere(3, radius);
  const double sphere_volume = testing::EnclosedVolume(sphere.vertices, sphere.triangles);
  const double area = 4 * M_PI * radius * radius;
  for (LatticeType type : {LatticeType::kBcc, LatticeType::kKuhn}) {
    SurfaceTetMeshOptions options;
    options.type = type;
    options.spacing = 0.5;
    TetMesh mesh;
    std::string error;
    SurfaceTetMeshStats stats;
    ASSERT_TRUE(
        MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error, &stats))
        << error;
    const double volume = MeshVolume(mesh);
    std::printf(
        "sphere r = %g, spacing %g, %s: %d elements (%d for surface vertices only), %d "
        "vertices, volume %.2f (surface encloses %.2f)\n",
        radius, options.spacing, type == LatticeType::kBcc ? "BCC" : "Kuhn", mesh.num_tets(),
        stats.surface_vertex_elements, mesh.num_vertices(), volume, sphere_volume);
    // Elements are kept by their centroids, so the error is a fraction of one layer.
    EXPECT_LT(std::abs(volume - sphere_volume), 0.25 * area * options.spacing);
    EXPECT_EQ(stats.num_elements, mesh.num_tets());
    EXPECT_EQ(stats.num_vertices, mesh.num_vertices());
    EXPECT_EQ(stats.num_elements,
              stats.inside_elements + stats.surface_vertex_elements + stats.bridge_elements);
    EXPECT_EQ(stats.dropped_components, 0);
    EXPECT_EQ(stats.num_components, 1);
    EXPECT_EQ(CountFaceComponents(mesh), 1);
    EXPECT_EQ(CountFaceComponents(mesh), 1);
    EXPECT_GT(stats.lattice_elements, stats.num_elements);
    ExpectValidAndEmbedding(mesh, sphere.vertices);
    // Every element is inside the sphere or touches its surface.
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      ASSERT_LT(mesh.vertices.col(v).norm(), radius + 2 * options.spacing);
    }
  }
}

TEST(SurfaceTetMesherTest, SphereWithHoleIsStillMeshed) {
  const double radius = 5;
  const SurfaceMesh sphere = testing::Icosphere(3, radius);
  // Remove a patch of triangles around vertex 0 (all triangles within 1.5 of it).
  std::vector<int> removed;
  for (int t = 0; t < sphere.num_triangles(); ++t) {
    if ((sphere.vertices.col(sphere.triangles(0, t)) - sphere.vertices.col(0)).norm() < 1.5) {
      removed.push_back(t);
    }
  }
  ASSERT_GE(removed.size(), 5u);
  const Eigen::Matrix3Xi open = testing::RemoveTriangles(sphere.triangles, removed);
  SurfaceTetMeshOptions options;
  options.spacing = 0.5;
  TetMesh closed_mesh, open_mesh;
  std::string error;
  ASSERT_TRUE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &closed_mesh, &error))
      << error;
  ASSERT_TRUE(MeshSurfaceInterior(sphere.vertices, open, options, &open_mesh, &error)) << error;
  std::printf("sphere with a hole of %d triangles: %d elements (closed: %d)\n",
              static_cast<int>(removed.size()), open_mesh.num_tets(), closed_mesh.num_tets());
  EXPECT_NEAR(MeshVolume(open_mesh), MeshVolume(closed_mesh), 0.02 * MeshVolume(closed_mesh));
  ExpectValidAndEmbedding(open_mesh, sphere.vertices);
}

TEST(SurfaceTetMesherTest, ShellKeepsALayerUnderTheSurface) {
  const double radius = 5;
  const SurfaceMesh sphere = testing::Icosphere(3, radius);
  SurfaceTetMeshOptions options;
  options.spacing = 0.5;
  options.shell_thickness = 1.5;
  TetMesh mesh;
  std::string error;
  SurfaceTetMeshStats stats;
  ASSERT_TRUE(
      MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error, &stats))
      << error;
  ExpectValidAndEmbedding(mesh, sphere.vertices);
  const TriangleBvh bvh(sphere.vertices, sphere.triangles);
  double farthest = 0;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    farthest = std::max(farthest, bvh.ClosestPoint(mesh.vertices.col(v)).distance);
  }
  std::printf("shell %g: %d elements, %d vertices, farthest vertex %.3f from the surface\n",
              options.shell_thickness, mesh.num_tets(), mesh.num_vertices(), farthest);
  EXPECT_LE(farthest, options.shell_thickness + options.spacing);
  EXPECT_GT(farthest, options.shell_thickness - options.spacing);
  // Hollow: about the volume of the spherical shell.
  const double inner = radius - options.shell_thickness;
  const double shell_volume = 4.0 / 3.0 * M_PI * (std::pow(radius, 3) - std::pow(inner, 3));
  EXPECT_NEAR(MeshVolume(mesh), shell_volume, 0.15 * shell_volume);
}

TEST(SurfaceTetMesherTest, IslandsWithoutSurfaceVerticesAreDropped) {
  // Two "sandwiches" of parallel squares facing away from each other: between the plates
  // the winding number is about 1, but the only vertices are the squares' corners, so
  // the two inside regions contain no surface vertex. The smaller one is an island.
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3i> faces;
  auto add_square = [&](const Eigen::Vector3d& centre, double half, bool up) {
    const int base = static_cast<int>(points.size());
    points.push_back(centre + Eigen::Vector3d(-half, -half, 0));
    points.push_back(centre + Eigen::Vector3d(half, -half, 0));
    points.push_back(centre + Eigen::Vector3d(half, half, 0));
    points.push_back(centre + Eigen::Vector3d(-half, half, 0));
    if (up) {
      faces.push_back({base, base + 1, base + 2});
      faces.push_back({base, base + 2, base + 3});
    } else {
      faces.push_back({base, base + 2, base + 1});
      faces.push_back({base, base + 3, base + 2});
    }
  };
  add_square({0, 0, 1}, 5, true);
  add_square({0, 0, -1}, 5, false);
  add_square({20, 0, 1}, 3, true);
  add_square({20, 0, -1}, 3, false);
  Eigen::Matrix3Xd vertices(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) vertices.col(i) = points[i];
  Eigen::Matrix3Xi triangles(3, faces.size());
  for (size_t i = 0; i < faces.size(); ++i) triangles.col(i) = faces[i];

  SurfaceTetMeshOptions options;
  options.spacing = 0.5;
  TetMesh all, largest;
  SurfaceTetMeshStats all_stats, largest_stats;
  std::string error;
  options.keep_largest_component = false;
  ASSERT_TRUE(MeshSurfaceInterior(vertices, triangles, options, &all, &error, &all_stats)) << error;
  options.keep_largest_component = true;
  ASSERT_TRUE(MeshSurfaceInterior(vertices, triangles, options, &largest, &error, &largest_stats))
      << error;
  std::printf(
      "islands: %d elements without dropping, %d with (%d components, %d elements "
      "dropped)\n",
      all.num_tets(), largest.num_tets(), largest_stats.dropped_components,
      largest_stats.dropped_elements);
  EXPECT_EQ(all_stats.dropped_components, 0);
  EXPECT_GE(largest_stats.dropped_components, 1);
  EXPECT_GE(largest_stats.dropped_elements, 100);
  EXPECT_LT(largest.num_tets(), all.num_tets() - 100);
  // The small sandwich's inside is gone; its corners' elements stay.
  int near_small = 0;
  for (int v = 0; v < largest.num_vertices(); ++v) {
    const Eigen::Vector3d p = largest.vertices.col(v);
    if (std::abs(p(0) - 20) < 2 && std::abs(p(1)) < 2 && std::abs(p(2)) < 0.9) ++near_small;
  }
  EXPECT_EQ(near_small, 0);
  ExpectValidAndEmbedding(largest, vertices);
}

TEST(SurfaceTetMesherTest, TouchingComponentsAreConnectedSeparateOnesAreNot) {
  // Two spheres far apart: two components, however many hanging elements were joined.
  const SurfaceMesh a = testing::Icosphere(2, 3.0);
  const SurfaceMesh b = testing::Icosphere(2, 2.0, Eigen::Vector3d(10, 0, 0));
  Eigen::Matrix3Xd vertices(3, a.num_vertices() + b.num_vertices());
  vertices << a.vertices, b.vertices;
  Eigen::Matrix3Xi triangles(3, a.num_triangles() + b.num_triangles());
  triangles << a.triangles, (b.triangles.array() + a.num_vertices()).matrix();
  SurfaceTetMeshOptions options;
  options.spacing = 0.5;
  options.connect_touching_components = false;
  TetMesh loose, joined;
  SurfaceTetMeshStats loose_stats, joined_stats;
  std::string error;
  ASSERT_TRUE(MeshSurfaceInterior(vertices, triangles, options, &loose, &error, &loose_stats))
      << error;
  options.connect_touching_components = true;
  ASSERT_TRUE(MeshSurfaceInterior(vertices, triangles, options, &joined, &error, &joined_stats))
      << error;
  std::printf(
      "two spheres: %d components without joining (%d elements), %d with (%d elements "
      "added)\n",
      loose_stats.num_components, loose.num_tets(), joined_stats.num_components,
      joined_stats.bridge_elements);
  EXPECT_EQ(loose_stats.bridge_elements, 0);
  EXPECT_EQ(CountFaceComponents(loose), loose_stats.num_components);
  EXPECT_GT(loose_stats.num_components, 2);  // elements hanging by a vertex or an edge
  EXPECT_EQ(joined_stats.num_components, 2);
  EXPECT_EQ(CountFaceComponents(joined), 2);
  EXPECT_EQ(joined.num_tets(), loose.num_tets() + joined_stats.bridge_elements);
  ExpectValidAndEmbedding(joined, vertices);
}

TEST(SurfaceTetMesherTest, SurfacesThatEncloseNothingFail) {
  SurfaceTetMeshOptions options;
  options.spacing = 0.5;
  TetMesh mesh;
  mesh.vertices = Eigen::Matrix3Xd::Zero(3, 1);
  std::string error;
  // A flat square patch (not aligned with the lattice).
  Eigen::Matrix3Xd square(3, 4);
  square << 0.13, 3.13, 3.13, 0.13,  //
      0.27, 0.27, 3.27, 3.27,        //
      0.71, 0.71, 0.71, 0.71;
  Eigen::Matrix3Xi square_triangles(3, 2);
  square_triangles << 0, 0, 1, 2, 2, 3;
  EXPECT_FALSE(MeshSurfaceInterior(square, square_triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "encloses nothing")) << error;
  EXPECT_TRUE(Contains(error, "open patch")) << error;
  EXPECT_EQ(mesh.num_vertices(), 1);  // untouched
  // A single triangle.
  EXPECT_FALSE(MeshSurfaceInterior(square, square_triangles.leftCols(1), options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "encloses nothing")) << error;
  // An inward-oriented sphere.
  const SurfaceMesh sphere = testing::Icosphere(2, 3.0);
  Eigen::Matrix3Xi reversed = sphere.triangles;
  reversed.row(1).swap(reversed.row(2));
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, reversed, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "oriented inward")) << error;
  // A shell thinner than any element's centroid distance... cannot be tested reliably at
  // zero, so use a tiny one.
  options.shell_thickness = 1e-6;
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "thicker shell")) << error;
}

TEST(SurfaceTetMesherTest, BadInputFails) {
  const SurfaceMesh sphere = testing::Icosphere(1, 3.0);
  SurfaceTetMeshOptions options;
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(
      MeshSurfaceInterior(Eigen::Matrix3Xd(3, 0), Eigen::Matrix3Xi(3, 0), options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "empty")) << error;
  EXPECT_FALSE(
      MeshSurfaceInterior(sphere.vertices, Eigen::Matrix3Xi(3, 0), options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "empty")) << error;
  Eigen::Matrix3Xd bad = sphere.vertices;
  bad(1, 7) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(MeshSurfaceInterior(bad, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "vertex 7 has a non-finite coordinate")) << error;
  Eigen::Matrix3Xi bad_index = sphere.triangles;
  bad_index(2, 5) = sphere.num_vertices();
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, bad_index, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "triangle 5 has vertex index")) << error;
  options.spacing = 0;
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "spacing")) << error;
  options.spacing = 1e-4;
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "too small")) << error;
  options.spacing = 1;
  options.shell_thickness = -1;
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "shell")) << error;
  // The options' one validation: a winding threshold out of [-1, 2] (it failed later as
  // "the surface encloses nothing"), threads below 1 (raised to 1 silently).
  options.shell_thickness = 0;
  options.winding_threshold = 5;
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "surface meshing options: winding_threshold")) << error;
  options.winding_threshold = 0.5;
  options.num_threads = 0;
  EXPECT_FALSE(MeshSurfaceInterior(sphere.vertices, sphere.triangles, options, &mesh, &error));
  EXPECT_TRUE(Contains(error, "num_threads")) << error;
}

TEST(IctFaceTest, MeshTheFaceWithAShell) {
  SurfaceMesh skin;
  ASSERT_TRUE(testing::ReadIctFaceDemo("skin_neutral.obj", &skin));
  ASSERT_EQ(skin.num_vertices(), 13294);
  std::string error;
  SurfaceTetMeshOptions options;
  options.spacing = 1.0;
  options.shell_thickness = 2.0;
  TetMesh mesh;
  SurfaceTetMeshStats stats;
  WallTimer timer;
  ASSERT_TRUE(MeshSurfaceInterior(skin.vertices, skin.triangles, options, &mesh, &error, &stats))
      << error;
  const double mesh_seconds = timer.Seconds();
  timer.Reset();
  const Embedding embedding = EmbedPoints(mesh, skin.vertices, 2);
  const double embed_seconds = timer.Seconds();
  std::printf(
      "ICT skin, spacing 1 cm, shell 2 cm: %d elements, %d vertices (lattice %d; %d "
      "elements only for surface vertices; %d islands of %d elements dropped; %d "
      "elements added to join touching pieces; %d component(s)); meshing %.3f s, "
      "embedding %d vertices %.3f s\n",
      mesh.num_tets(), mesh.num_vertices(), stats.lattice_elements, stats.surface_vertex_elements,
      stats.dropped_components, stats.dropped_elements, stats.bridge_elements, stats.num_components,
      mesh_seconds, skin.num_vertices(), embed_seconds);
  EXPECT_EQ(stats.num_components, 1);
  std::string validation;
  EXPECT_TRUE(ValidateTetMesh(mesh, "face", &validation)) << validation;
  int outside = 0;
  for (int i = 0; i < embedding.num_points(); ++i) outside += embedding.outside_distance[i] > 0;
  EXPECT_EQ(outside, 0);
  EXPECT_EQ(embedding.num_points(), 13294);
}

}  // namespace
}  // namespace aqs
