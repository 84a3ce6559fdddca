#include "physics/stiffness_assembly.h"

#include <random>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "physics/boundary_conditions.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"
#include "util/parallel_for.h"

namespace aqs {
namespace {

TEST(StiffnessPatternTest, ColumnsSortedUpperAndComplete) {
  const TetMesh mesh = testing::BarMesh(3, 2, 2, 1.0);
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  const StiffnessPattern pattern(mesh.tets, FixedVertexMask(bc, mesh.num_vertices()));
  EXPECT_EQ(pattern.num_free_vertices(), mesh.num_vertices() - static_cast<int>(bc.vertices.size()));
  for (int j = 0; j < pattern.num_dofs(); ++j) {
    const int64_t begin = pattern.column_starts()[j], end = pattern.column_starts()[j + 1];
    ASSERT_LT(begin, end);
    EXPECT_EQ(pattern.row_indices()[end - 1], j) << "diagonal last";
    for (int64_t p = begin; p + 1 < end; ++p) {
      EXPECT_LT(pattern.row_indices()[p], pattern.row_indices()[p + 1]);
    }
  }
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    EXPECT_EQ(pattern.free_index(pattern.vertex_of_free(f)), f);
  }
}

TEST(StiffnessPatternTest, CouplingsAddBlocksFoundByVertexBlockOffset) {
  const TetMesh mesh = testing::BarMesh(3, 2, 2, 1.0);
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  const std::vector<bool> fixed = FixedVertexMask(bc, mesh.num_vertices());
  // Couple a fixed vertex (dropped), the first free one and the last one (far apart in
  // the mesh).
  const int n = mesh.num_vertices();
  const StiffnessPattern plain(mesh.tets, fixed);
  const std::vector<std::vector<int>> couplings = {{bc.vertices[0], plain.vertex_of_free(0), n - 1}};
  const StiffnessPattern coupled(mesh.tets, fixed, couplings);
  EXPECT_GT(coupled.num_nonzeros(), plain.num_nonzeros());
  // Which vertex pairs share an element or the coupling.
  std::vector<std::vector<char>> linked(n, std::vector<char>(n, 0));
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) {
      for (int l = 0; l < 4; ++l) linked[mesh.tets(k, e)][mesh.tets(l, e)] = 1;
    }
  }
  for (int u : couplings[0]) {
    for (int v : couplings[0]) linked[u][v] = 1;
  }
  for (int u = 0; u < n; ++u) {
    for (int v = 0; v < n; ++v) {
      const int fu = coupled.free_index(u), fv = coupled.free_index(v);
      for (int d = 0; d < 3; ++d) {
        const int64_t offset = coupled.VertexBlockOffset(u, v, d);
        if (fu < 0 || fv < 0 || fu > fv || !linked[u][v]) {
          EXPECT_EQ(offset, -1) << u << " " << v;
          continue;
        }
        ASSERT_GE(offset, 0) << u << " " << v;
        const int rows = u == v ? d + 1 : 3;
        for (int c = 0; c < rows; ++c) {
          // Entry (3 fu + c, 3 fv + d): in column 3 fv + d, at row 3 fu + c.
          EXPECT_EQ(coupled.row_indices()[offset + c], 3 * fu + c);
          EXPECT_GE(offset + c, coupled.column_starts()[3 * fv + d]);
          EXPECT_LT(offset + c, coupled.column_starts()[3 * fv + d + 1]);
        }
      }
    }
  }
  // Element blocks agree with BlockOffset.
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) {
      for (int l = 0; l < 4; ++l) {
        for (int d = 0; d < 3; ++d) {
          const int64_t by_element = coupled.BlockOffset(e, k, l, d);
          if (by_element >= 0) {
            EXPECT_EQ(by_element, coupled.VertexBlockOffset(mesh.tets(k, e), mesh.tets(l, e), d));
          }
        }
      }
    }
  }
}

class StiffnessAssemblyTest : public ::testing::Test {
 protected:
  StiffnessAssemblyTest()
      : mesh_(testing::BarMesh(3, 2, 1, 0.5)),
        model_(mesh_, RandomMu(mesh_.num_tets())),
        bc_(testing::LeftFaceFixed(mesh_)),
        pattern_(mesh_.tets, FixedVertexMask(bc_, mesh_.num_vertices())) {}

  static Eigen::VectorXd RandomMu(int n) {
    std::mt19937 rng(8);
    std::uniform_real_distribution<double> uniform(0.5, 2.0);
    Eigen::VectorXd mu(n);
    for (int i = 0; i < n; ++i) mu[i] = uniform(rng);
    return mu;
  }

  // Gradient of E on the free DOFs as a function of the free DOFs.
  Eigen::VectorXd FreeGradient(const Eigen::VectorXd& free, const Eigen::Matrix3Xd& base,
                               const ActuationMatrix& a) const {
    Eigen::Matrix3Xd x = base;
    for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
      x.col(pattern_.vertex_of_free(f)) = free.segment<3>(3 * f);
    }
    Eigen::Matrix3Xd gradient;
    model_.EnergyAndGradient(x, a, &gradient);
    Eigen::VectorXd out(pattern_.num_dofs());
    for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
      out.segment<3>(3 * f) = gradient.col(pattern_.vertex_of_free(f));
    }
    return out;
  }

  TetMesh mesh_;
  ShapeTargetModel model_;
  BoundaryConditions bc_;
  StiffnessPattern pattern_;
};

TEST_F(StiffnessAssemblyTest, ExactStiffnessMatchesFiniteDifferencesOfForces) {
  std::mt19937 rng(12);
  std::normal_distribution<double> normal(0.0, 0.06);
  for (int trial = 0; trial < 4; ++trial) {
    const ActuationMatrix a = testing::RandomActuation(model_.num_elements(), 0.3, &rng);
    Eigen::Matrix3Xd x = mesh_.vertices;
    for (int i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
    if (trial == 2) x *= 0.6;  // compressed: indefinite element Hessians
    if (trial == 1) x = testing::RandomRotation(&rng) * x;  // fixed vertices turned too
    std::vector<double> values;
    AssembleStiffness(model_, pattern_, x, a, StiffnessKind::kExact, 2, &values);
    const Eigen::MatrixXd k = DenseFromUpperCsc(pattern_, values);
    Eigen::VectorXd free(pattern_.num_dofs());
    for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
      free.segment<3>(3 * f) = x.col(pattern_.vertex_of_free(f));
    }
    const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(
        [&](const Eigen::VectorXd& v) { return FreeGradient(v, x, a); }, free, 1e-6);
    EXPECT_LT(testing::RelativeError(k, numeric), 1e-7) << "trial " << trial;
    // Serial and threaded assembly agree.
    std::vector<double> serial;
    AssembleStiffness(model_, pattern_, x, a, StiffnessKind::kExact, 1, &serial);
    EXPECT_LT(testing::RelativeError(DenseFromUpperCsc(pattern_, serial), k), 1e-13);
  }
}

// With several threads (a mesh of more than two grains of 256 elements, so that the
// threaded path runs), the energy, gradient and stiffness are the same to the last bit
// in every run (fixed chunks per thread, partial sums reduced in thread order; with a
// shared counter they differed in every one of 200 runs), and agree with one thread's to
// round-off.
TEST(StiffnessAssemblyThreadsTest, ThreadedResultsAreReproducibleAndAgreeWithSerial) {
  const TetMesh mesh = testing::BarMesh(6, 5, 4, 0.3);
  const ShapeTargetModel model(mesh, 1.0);
  ASSERT_GT(ParallelForThreadCount(2, model.num_elements()), 1) << model.num_elements();
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  const StiffnessPattern pattern(mesh.tets, FixedVertexMask(bc, mesh.num_vertices()));
  std::mt19937 rng(7);
  const Eigen::Matrix3Xd x = testing::JitteredVertices(mesh, 0.03, &rng);
  const ActuationMatrix a = testing::SmoothActuation(mesh, 0.3);
  Eigen::Matrix3Xd first_gradient;
  const double first_energy = model.EnergyAndGradient(x, a, &first_gradient, 2);
  std::vector<double> first_values;
  AssembleStiffness(model, pattern, x, a, StiffnessKind::kExact, 2, &first_values);
  const double first_plain = model.Energy(x, a, 2);
  EXPECT_NEAR(first_plain, first_energy, 1e-13 * first_energy);
  for (int run = 0; run < 20; ++run) {
    Eigen::Matrix3Xd gradient;
    EXPECT_EQ(model.EnergyAndGradient(x, a, &gradient, 2), first_energy) << run;
    EXPECT_EQ((gradient - first_gradient).cwiseAbs().maxCoeff(), 0.0) << run;
    EXPECT_EQ(model.Energy(x, a, 2), first_plain) << run;
    std::vector<double> values;
    AssembleStiffness(model, pattern, x, a, StiffnessKind::kExact, 2, &values);
    EXPECT_TRUE(values == first_values) << run;
  }
  Eigen::Matrix3Xd serial_gradient;
  const double serial_energy = model.EnergyAndGradient(x, a, &serial_gradient, 1);
  EXPECT_NEAR(first_energy, serial_energy, 1e-13 * std::abs(serial_energy));
  EXPECT_LT(testing::RelativeError(first_gradient, serial_gradient), 1e-13);
  std::vector<double> serial_values;
  AssembleStiffness(model, pattern, x, a, StiffnessKind::kExact, 1, &serial_values);
  EXPECT_LT(testing::RelativeError(DenseFromUpperCsc(pattern, first_values),
                                   DenseFromUpperCsc(pattern, serial_values)),
            1e-13);
}

// One element, no vertex fixed (12 DOFs), at every state the derivative tests share:
// near rest, random, rotated, compressed, near-degenerate polar decompositions, inverted,
// anisotropic and sheared actuations; x = R F X with a random rotation R. The exact
// element Hessian, as assembled, against differenced forces, and the forces against
// the differenced energy.
TEST(StiffnessAssemblyElementTest, ExactStiffnessMatchesDifferencedForcesAtEveryElementState) {
  const TetMesh mesh = testing::OneTetMesh();
  const ShapeTargetModel model(mesh, 0.9);
  const StiffnessPattern pattern(mesh.tets, std::vector<bool>(4, false));
  std::mt19937 rng(19);
  int checked = 0;
  for (const auto& state : testing::DerivativeTestStates(5, 20)) {
    const Eigen::Matrix3Xd x = testing::RandomRotation(&rng) * state.f * mesh.vertices;
    ActuationMatrix a(6, 1);
    a.col(0) = ActuationFromSymmetric(state.s);
    std::vector<double> values;
    AssembleStiffness(model, pattern, x, a, StiffnessKind::kExact, 1, &values);
    const Eigen::MatrixXd k = DenseFromUpperCsc(pattern, values);
    auto gradient = [&](const Eigen::VectorXd& flat) -> Eigen::VectorXd {
      Eigen::Matrix3Xd g;
      model.EnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, 4), a, &g, 1);
      return Eigen::Map<const Eigen::VectorXd>(g.data(), 12);
    };
    // Next to a near-degenerate polar decomposition the rotation turns fast with x:
    // differences must stay well inside the singular-value gap.
    const bool near_degenerate = state.name.rfind("near_degenerate", 0) == 0;
    const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(
        gradient, Eigen::Map<const Eigen::VectorXd>(x.data(), 12), near_degenerate ? 1e-8 : 1e-5);
    EXPECT_LT(testing::RelativeError(k, numeric), near_degenerate ? 1e-6 : 1e-8) << state.name;
    // And the forces themselves against the differenced energy.
    const Eigen::VectorXd forces = gradient(Eigen::Map<const Eigen::VectorXd>(x.data(), 12));
    const Eigen::VectorXd numeric_forces = testing::CentralDifferenceGradient(
        [&](const Eigen::VectorXd& flat) {
          return model.Energy(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, 4), a);
        },
        Eigen::Map<const Eigen::VectorXd>(x.data(), 12), near_degenerate ? 1e-8 : 1e-5);
    EXPECT_LT(testing::RelativeError(forces, numeric_forces), near_degenerate ? 1e-6 : 1e-8)
        << state.name;
    // The projection: positive semi-definite always; and at x = R S X, where the element
    // is at its target (E = 0, a minimum), K is already, and the projection leaves it.
    const Eigen::Matrix3Xd at_target = testing::RandomRotation(&rng) * state.s * mesh.vertices;
    for (const Eigen::Matrix3Xd* y : {&x, &at_target}) {
      std::vector<double> exact_values, projected_values;
      AssembleStiffness(model, pattern, *y, a, StiffnessKind::kExact, 1, &exact_values);
      AssembleStiffness(model, pattern, *y, a, StiffnessKind::kProjected, 1, &projected_values);
      const Eigen::MatrixXd exact = DenseFromUpperCsc(pattern, exact_values);
      const Eigen::MatrixXd projected = DenseFromUpperCsc(pattern, projected_values);
      const double scale = exact.norm();
      EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(projected).eigenvalues().minCoeff(),
                -1e-12 * scale)
          << state.name;
      if (y == &at_target) {
        EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(exact).eigenvalues().minCoeff(),
                  -1e-12 * scale)
            << state.name;
        EXPECT_LT(testing::RelativeError(projected, exact), 1e-12) << state.name;
      }
    }
    ++checked;
  }
  EXPECT_GE(checked, 10);
}

TEST_F(StiffnessAssemblyTest, ProjectedStiffnessIsPositiveSemiDefinite) {
  std::mt19937 rng(13);
  const ActuationMatrix a = testing::RandomActuation(model_.num_elements(), 0.3, &rng);
  const Eigen::Matrix3Xd x = 0.5 * mesh_.vertices;  // strongly compressed
  std::vector<double> exact, projected;
  AssembleStiffness(model_, pattern_, x, a, StiffnessKind::kExact, 2, &exact);
  AssembleStiffness(model_, pattern_, x, a, StiffnessKind::kProjected, 2, &projected);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> exact_eig(DenseFromUpperCsc(pattern_, exact));
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> projected_eig(
      DenseFromUpperCsc(pattern_, projected));
  EXPECT_LT(exact_eig.eigenvalues().minCoeff(), 0.0) << "the state should be indefinite";
  EXPECT_GE(projected_eig.eigenvalues().minCoeff(),
            -1e-12 * projected_eig.eigenvalues().maxCoeff());
  // At rest with S = I every element Hessian is PSD already: both kinds agree.
  const ActuationMatrix identity = IdentityActuations(model_.num_elements());
  AssembleStiffness(model_, pattern_, mesh_.vertices, identity, StiffnessKind::kExact, 2, &exact);
  AssembleStiffness(model_, pattern_, mesh_.vertices, identity, StiffnessKind::kProjected, 2,
                    &projected);
  EXPECT_LT(testing::RelativeError(DenseFromUpperCsc(pattern_, projected),
                                   DenseFromUpperCsc(pattern_, exact)),
            1e-12);
}

TEST_F(StiffnessAssemblyTest, RotationFixedStiffnessIsTheHessianWithRotationsHeld) {
  // E_R(x) = sum_e V_e mu_e |F_e(x) - R_e S_e|^2 with every R_e held at its polar
  // rotation at x0: a quadratic in x whose Hessian kRotationFixed assembles, at any
  // state (random, deformed, rotated, compressed).
  std::mt19937 rng(14);
  std::normal_distribution<double> normal(0.0, 0.06);
  for (int trial = 0; trial < 3; ++trial) {
    const ActuationMatrix a = testing::RandomActuation(model_.num_elements(), 0.3, &rng);
    Eigen::Matrix3Xd x0 = mesh_.vertices;
    for (int i = 0; i < x0.size(); ++i) x0.data()[i] += normal(rng);
    if (trial == 1) {
      const Eigen::Matrix3d rotation =
          Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
      x0 = (rotation * x0).eval();
    }
    if (trial == 2) x0 *= 0.5;
    std::vector<Eigen::Matrix3d> target(model_.num_elements());
    for (int e = 0; e < model_.num_elements(); ++e) {
      const ShapeTargetElement element = model_.Element(x0, a, e);
      target[e] = element.rotation() * element.s();
    }
    auto energy = [&](const Eigen::VectorXd& free) {
      Eigen::Matrix3Xd x = x0;
      for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
        x.col(pattern_.vertex_of_free(f)) = free.segment<3>(3 * f);
      }
      double sum = 0;
      for (int e = 0; e < model_.num_elements(); ++e) {
        sum += model_.rest_shape(e).volume * model_.mu(e) *
               (model_.DeformationGradient(x, e) - target[e]).squaredNorm();
      }
      return sum;
    };
    Eigen::VectorXd free(pattern_.num_dofs());
    for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
      free.segment<3>(3 * f) = x0.col(pattern_.vertex_of_free(f));
    }
    // The Hessian of the quadratic by second central differences (exact for a
    // quadratic, up to round-off).
    const int n = pattern_.num_dofs();
    const double h = 1e-3;
    Eigen::MatrixXd numeric(n, n);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        Eigen::VectorXd pp = free, pm = free, mp = free, mm = free;
        pp[i] += h, pp[j] += h;
        pm[i] += h, pm[j] -= h;
        mp[i] -= h, mp[j] += h;
        mm[i] -= h, mm[j] -= h;
        numeric(i, j) = (energy(pp) - energy(pm) - energy(mp) + energy(mm)) / (4 * h * h);
      }
    }
    std::vector<double> values;
    AssembleStiffness(model_, pattern_, x0, a, StiffnessKind::kRotationFixed, 2, &values);
    EXPECT_LT(testing::RelativeError(DenseFromUpperCsc(pattern_, values), numeric), 1e-6)
        << "trial " << trial;
  }
}

}  // namespace
}  // namespace aqs
