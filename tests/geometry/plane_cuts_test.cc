#include "geometry/plane_cuts.h"

#include <gtest/gtest.h>

#include "equilibrium/embedded_attachments.h"
#include "equilibrium/quasistatic_solver.h"
#include "mesh/boundary_surface.h"
#include "mesh/lattice.h"

namespace aqs {
namespace {

TetMesh Bar() {
  LatticeOptions options;
  options.nx = 8;
  options.ny = 2;
  options.nz = 2;
  options.spacing = 0.5;
  options.type = LatticeType::kBcc;
  return MakeLatticeMesh(options);  // [0, 4] x [0, 1] x [0, 1]
}

// A horizontal cut through the bar's middle (y = 0.55, off the lattice planes), from x = 2 on.
PlaneCut MiddleCut() {
  PlaneCut cut;
  cut.normal = Eigen::Vector3d::UnitY();
  cut.offset = 0.55;
  cut.region = Eigen::AlignedBox3d(Eigen::Vector3d(2.0, -1, -1), Eigen::Vector3d(5, 2, 2));
  return cut;
}

double TotalVolume(const TetMesh& mesh) {
  double v = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) v += std::abs(SignedTetVolume(mesh, mesh.vertices, e));
  return v;
}

TEST(PlaneCutsTest, DuplicatesCrossedElementsIntoAValidMesh) {
  const TetMesh bar = Bar();
  const CutMesh cut = ApplyPlaneCuts(bar, {MiddleCut()});
  const int added = cut.mesh.num_tets() - bar.num_tets();
  EXPECT_GT(added, 0);
  std::string error;
  EXPECT_TRUE(ValidateTetMesh(cut.mesh, "cut bar", &error)) << error;
  int plus = 0, minus = 0;
  for (int e = 0; e < cut.mesh.num_tets(); ++e) {
    const int side = cut.element_side[0][e];
    plus += side == 1;
    minus += side == -1;
    if (side != 0) {
      const int twin = cut.element_twin[0][e];
      ASSERT_GE(twin, 0);
      EXPECT_EQ(cut.element_twin[0][twin], e);
      EXPECT_EQ(cut.element_side[0][twin], -side);
      // Same geometry.
      for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(cut.mesh.vertices.col(cut.mesh.tets(k, e)),
                  cut.mesh.vertices.col(cut.mesh.tets(k, twin)));
      }
    }
  }
  EXPECT_EQ(plus, added);
  EXPECT_EQ(minus, added);
  // Ghosts copy original vertices; the duplicated volume is the crossed elements'.
  for (int v = bar.num_vertices(); v < cut.mesh.num_vertices(); ++v) {
    EXPECT_EQ(cut.mesh.vertices.col(v), bar.vertices.col(cut.original_vertex[v]));
  }
  EXPECT_GT(TotalVolume(cut.mesh), TotalVolume(bar));
  // The cut opens new boundary: the boundary surface grows.
  EXPECT_GT(ExtractBoundarySurface(cut.mesh).triangles.cols(),
            ExtractBoundarySurface(bar).triangles.cols());
}

// Two cuts whose regions share elements: the middle cut and a vertical one at x = 3.1
// (off the lattice planes), over the whole bar.
std::vector<PlaneCut> CrossingCuts() {
  PlaneCut vertical;
  vertical.normal = Eigen::Vector3d::UnitX();
  vertical.offset = 3.1;
  vertical.region = Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(5, 2, 2));
  return {MiddleCut(), vertical};
}

TEST(PlaneCutsTest, ElementsCutTwiceKeepTheirTwinsAcrossBothCuts) {
  const CutMesh cut = ApplyPlaneCuts(Bar(), CrossingCuts());
  int cut_twice = 0;
  for (int e = 0; e < cut.mesh.num_tets(); ++e) {
    cut_twice += cut.element_side[0][e] != 0 && cut.element_side[1][e] != 0;
    for (int c = 0; c < 2; ++c) {
      const int side = cut.element_side[c][e];
      if (side == 0) continue;
      const int twin = cut.element_twin[c][e];
      ASSERT_GE(twin, 0) << "element " << e << " cut " << c;
      EXPECT_EQ(cut.element_twin[c][twin], e);
      EXPECT_EQ(cut.element_side[c][twin], -side);
      EXPECT_EQ(cut.element_side[1 - c][twin], cut.element_side[1 - c][e]);
      for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(cut.mesh.vertices.col(cut.mesh.tets(k, e)),
                  cut.mesh.vertices.col(cut.mesh.tets(k, twin)));
      }
    }
  }
  EXPECT_GT(cut_twice, 0);  // the four copies of each element both cuts split
}

TEST(PlaneCutsTest, PointsReachTheirQuadrantFromAnyCopyOfTheirElement) {
  const std::vector<PlaneCut> cuts = CrossingCuts();
  const CutMesh cut = ApplyPlaneCuts(Bar(), cuts);
  // Points in the four quadrants about the cuts' crossing line (y = 0.55, x = 3.1).
  Eigen::Matrix3Xd points(3, 4);
  points << 3.05, 3.15, 3.05, 3.15,  //
      0.6, 0.6, 0.5, 0.5,            //
      0.4, 0.4, 0.4, 0.4;
  const Embedding located = EmbedPoints(cut.mesh, points, 1);
  for (int i = 0; i < points.cols(); ++i) {
    // Every copy of the point's element: the elements at the same place.
    std::vector<int> copies;
    for (int e = 0; e < cut.mesh.num_tets(); ++e) {
      bool same = true;
      for (int k = 0; k < 4; ++k) {
        same = same && cut.mesh.vertices.col(cut.mesh.tets(k, e)) ==
                           cut.mesh.vertices.col(cut.mesh.tets(k, located.element[i]));
      }
      if (same) copies.push_back(e);
    }
    ASSERT_EQ(copies.size(), 4u) << "point " << i;
    const int side_y = points(1, i) >= 0.55 ? 1 : -1, side_x = points(0, i) >= 3.1 ? 1 : -1;
    for (const int start : copies) {
      Embedding embedding = located;
      embedding.element[i] = start;
      AssignEmbeddingSides(cut, cuts, points, Eigen::Matrix3Xd(), 0.0, &embedding);
      EXPECT_EQ(cut.element_side[0][embedding.element[i]], side_y) << i << " from " << start;
      EXPECT_EQ(cut.element_side[1][embedding.element[i]], side_x) << i << " from " << start;
    }
  }
}

TEST(PlaneCutsTest, TheTwoSidesSeparateUnderOpposingPulls) {
  const TetMesh bar = Bar();
  const std::vector<PlaneCut> cuts = {MiddleCut()};
  // Points just above and just below the cut at the free end.
  Eigen::Matrix3Xd points(3, 2);
  points << 3.8, 3.8,  //
      0.6, 0.5,        //
      0.5, 0.5;
  double gaps[2];
  for (int with_cut = 0; with_cut < 2; ++with_cut) {
    const CutMesh cut = with_cut ? ApplyPlaneCuts(bar, cuts) : ApplyPlaneCuts(bar, {});
    Embedding embedding = EmbedPoints(cut.mesh, points, 1);
    if (with_cut) {
      AssignEmbeddingSides(cut, cuts, points, Eigen::Matrix3Xd(), 0.0, &embedding);
      EXPECT_EQ(cut.element_side[0][embedding.element[0]], 1);
      EXPECT_EQ(cut.element_side[0][embedding.element[1]], -1);
    }
    const ShapeTargetModel model(cut.mesh, 1.0);
    BoundaryConditions bc;
    for (int v = 0; v < cut.mesh.num_vertices(); ++v) {
      if (cut.mesh.vertices(0, v) < 1e-9) bc.vertices.push_back(v);
    }
    QuasistaticSolver solver(model, bc);
    EmbeddedAttachments springs(embedding, cut.mesh.tets, Eigen::Vector2d(5, 5),
                                cut.mesh.vertices);
    Eigen::Matrix3Xd targets = points;
    targets(1, 0) += 0.3;
    targets(1, 1) -= 0.3;
    springs.targets() = targets;
    solver.AddEnergyTerm(&springs);
    const QuasistaticSolveReport report = solver.Solve();
    ASSERT_TRUE(report.converged) << report.Summary();
    const Eigen::Matrix3Xd moved = springs.Points(solver.positions());
    gaps[with_cut] = moved(1, 0) - moved(1, 1);
  }
  // Without the cut the two points (0.1 apart) stay bound; with it they part.
  EXPECT_LT(gaps[0], 0.2);
  EXPECT_GT(gaps[1], 0.4);
}

TEST(PlaneCutsTest, NormalsDecideTheSideNextToTheCut) {
  const TetMesh bar = Bar();
  const std::vector<PlaneCut> cuts = {MiddleCut()};
  const CutMesh cut = ApplyPlaneCuts(bar, cuts);
  // Two points a hair below the cut (y = 0.55): the first faces down (its material is
  // above: the + side), the second faces up (material below: -).
  Eigen::Matrix3Xd points(3, 2), normals(3, 2);
  points << 3.3, 3.3,  //
      0.549, 0.549,    //
      0.5, 0.5;
  normals << 0, 0,  //
      -1, 1,        //
      0, 0;
  Embedding embedding = EmbedPoints(cut.mesh, points, 1);
  AssignEmbeddingSides(cut, cuts, points, normals, 0.05, &embedding);
  EXPECT_EQ(cut.element_side[0][embedding.element[0]], 1);
  EXPECT_EQ(cut.element_side[0][embedding.element[1]], -1);
  // Beyond the margin, the position decides.
  AssignEmbeddingSides(cut, cuts, points, normals, 1e-4, &embedding);
  EXPECT_EQ(cut.element_side[0][embedding.element[0]], -1);
}

TEST(PlaneCutsTest, ParsesAndRejects) {
  PlaneCut cut;
  std::string error;
  ASSERT_TRUE(ParsePlaneCut("0,2,0,-6.7@-2.4,-4,9,2.4,-2.7,13", &cut, &error)) << error;
  EXPECT_EQ(cut.normal, Eigen::Vector3d::UnitY());
  EXPECT_DOUBLE_EQ(cut.offset, -3.35);
  ASSERT_TRUE(ParsePlaneCut("0,1,0.14,-1.76,0.06,0,0@-2.6,-4.2,8.5,2.6,-2.5,13.5", &cut, &error))
      << error;
  EXPECT_NEAR(cut.quadratic.x(), 0.06 / std::sqrt(1 + 0.14 * 0.14), 1e-15);
  EXPECT_FALSE(ParsePlaneCut("0,1,0,1,2@0,0,0,1,1,1", &cut, &error));
  EXPECT_FALSE(ParsePlaneCut("0,1,0,1", &cut, &error));
  EXPECT_NE(error.find("expected nx,ny,nz,offset[,qx,qy,qz]@"), std::string::npos) << error;
  EXPECT_FALSE(ParsePlaneCut("0,0,0,1@0,0,0,1,1,1", &cut, &error));
  EXPECT_FALSE(ParsePlaneCut("0,1,0,1@0,0,0,1,x,1", &cut, &error));
  EXPECT_FALSE(ParsePlaneCut("0,1,0,1@0,0,0,-1,1,1", &cut, &error));
}

}  // namespace
}  // namespace aqs
