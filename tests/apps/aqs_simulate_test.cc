// Runs the aqs_simulate binary on meshes from other tools and on malformed inputs.

#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "io/actuation_io.h"
#include "io/vertex_list_io.h"
#include "mesh/mesh_io.h"
#include "physics/shape_target_model.h"
#include "testing/run_command.h"
#include "testing/source_data.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::AppPath;
using testing::DataPath;
using testing::RunCommand;

std::string Simulate(const std::string& flags) { return AppPath("aqs_simulate") + " " + flags; }

// The loss a run printed ("loss <value>").
double PrintedLoss(const std::string& output) {
  const size_t pos = output.find("\nloss ");
  EXPECT_NE(pos, std::string::npos) << output;
  return std::stod(output.substr(pos + 6));
}

TEST(AqsSimulateTest, FingerExampleWritesAllOutputs) {
  testing::TempDir dir;
  const std::string finger = DataPath("examples/finger/");
  const testing::CommandResult run = RunCommand(Simulate(
      "--mesh=" + finger + "finger.msh --fixed=" + finger + "fixed.txt --actuation=" + finger +
      "actuation.txt --output=" + dir.File("x.mesh") + "," + dir.File("x.vtu") + "," +
      dir.File("x.obj")));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("solve: converged"), std::string::npos) << run.output;
  // --ensure_stable (default on) checked the result: a stable equilibrium.
  EXPECT_NE(run.output.find(" factorizations, stable"), std::string::npos) << run.output;
  TetMesh deformed, rest;
  std::string error;
  ASSERT_TRUE(ReadTetMeshFile(dir.File("x.mesh"), &deformed, &error)) << error;
  ASSERT_TRUE(ReadTetMesh(finger + "finger.msh", &rest, &error)) << error;
  EXPECT_EQ(deformed.num_vertices(), rest.num_vertices());
  EXPECT_EQ(deformed.tets, rest.tets) << "same element order";
  // The muscle on the +x side bends the tip towards +x.
  int tip = 0;
  for (int v = 0; v < rest.num_vertices(); ++v) {
    if (rest.vertices(2, v) > rest.vertices(2, tip)) tip = v;
  }
  EXPECT_GT(deformed.vertices(0, tip) - rest.vertices(0, tip), 0.5);
  // Forces at tolerance, checked independently of the app.
  BoundaryConditions bc;
  ASSERT_TRUE(ReadFixedVertices(finger + "fixed.txt", rest.vertices, &bc, &error));
  ActuationMatrix a;
  ASSERT_TRUE(ReadActuation(finger + "actuation.txt", rest.num_tets(), &a, &error));
  const ShapeTargetModel model(rest, 1.0);
  Eigen::Matrix3Xd gradient;
  model.EnergyAndGradient(deformed.vertices, a, &gradient);
  std::vector<bool> fixed(rest.num_vertices(), false);
  for (int v : bc.vertices) fixed[v] = true;
  double max_force = 0;
  for (int v = 0; v < rest.num_vertices(); ++v) {
    if (!fixed[v]) max_force = std::max(max_force, gradient.col(v).norm());
  }
  EXPECT_LE(max_force, 1e-6 * model.force_scale());
  SurfaceMesh surface;
  ASSERT_TRUE(ReadObj(dir.File("x.obj"), &surface, &error)) << error;
  EXPECT_GT(surface.num_triangles(), 100);
  std::ifstream vtu(dir.File("x.vtu"));
  std::stringstream text;
  text << vtu.rdbuf();
  for (const char* field : {"displacement", "residual_force", "actuation", "energy_density",
                            "volume_ratio"}) {
    EXPECT_NE(text.str().find(std::string("Name=\"") + field + "\""), std::string::npos) << field;
  }
}

// The gradient the app writes agrees with central differences of the loss the app
// prints, re-solving the equilibrium (TetGen mesh, heterogeneous actuation).
TEST(AqsSimulateTest, GradientMatchesFiniteDifferencesOnTetgenMesh) {
  testing::TempDir dir;
  const std::string mesh_path = DataPath("test_meshes/torus.node");
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadTetMesh(mesh_path, &mesh, &error)) << error;
  // Fix the vertices with x < -1 (a section of the ring).
  std::vector<int> fixed;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) < -1.0) fixed.push_back(v);
  }
  ASSERT_GT(fixed.size(), 10u);
  ASSERT_TRUE(WriteVertexList(dir.File("fixed.txt"), fixed, "", &error));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(-0.15, 0.15);
  ActuationMatrix a = IdentityActuations(mesh.num_tets());
  for (int i = 0; i < a.size(); ++i) a.data()[i] += uniform(rng);
  ASSERT_TRUE(WriteActuation(dir.File("a.txt"), a, "", &error));
  // Target: the equilibrium of another actuation.
  ActuationMatrix other = a;
  for (int i = 0; i < other.size(); ++i) other.data()[i] += uniform(rng);
  ASSERT_TRUE(WriteActuation(dir.File("b.txt"), other, "", &error));
  const std::string common = "--mesh=" + mesh_path + " --fixed=" + dir.File("fixed.txt") +
                             " --tolerance=1e-12 --threads=1";
  ASSERT_EQ(RunCommand(Simulate(common + " --actuation=" + dir.File("b.txt") +
                                " --output=" + dir.File("target.mesh")))
                .exit_code,
            0);
  const testing::CommandResult base = RunCommand(
      Simulate(common + " --actuation=" + dir.File("a.txt") + " --output=" + dir.File("x.mesh") +
               " --loss_target=" + dir.File("target.mesh") + " --gradient=" + dir.File("g.txt")));
  ASSERT_EQ(base.exit_code, 0) << base.output;
  ActuationMatrix gradient;
  ASSERT_TRUE(ReadActuation(dir.File("g.txt"), mesh.num_tets(), &gradient, &error)) << error;
  // Check the components with the largest gradient, each by a central difference.
  std::vector<int> order(gradient.size());
  for (int i = 0; i < gradient.size(); ++i) order[i] = i;
  std::partial_sort(order.begin(), order.begin() + 4, order.end(), [&](int i, int j) {
    return std::abs(gradient.data()[i]) > std::abs(gradient.data()[j]);
  });
  const double h = 1e-4;
  for (int c = 0; c < 4; ++c) {
    double loss[2];
    for (int side = 0; side < 2; ++side) {
      ActuationMatrix perturbed = a;
      perturbed.data()[order[c]] += side == 0 ? h : -h;
      ASSERT_TRUE(WriteActuation(dir.File("p.txt"), perturbed, "", &error));
      const testing::CommandResult run = RunCommand(Simulate(
          common + " --actuation=" + dir.File("p.txt") + " --output=" + dir.File("p.mesh") +
          " --loss_target=" + dir.File("target.mesh") + " --initial=" + dir.File("x.mesh")));
      ASSERT_EQ(run.exit_code, 0) << run.output;
      loss[side] = PrintedLoss(run.output);
    }
    const double numeric = (loss[0] - loss[1]) / (2 * h);
    const double analytic = gradient.data()[order[c]];
    EXPECT_NEAR(analytic, numeric, 1e-5 * std::abs(numeric) + 1e-12)
        << "element " << order[c] / 6 << " number " << order[c] % 6;
  }
}

TEST(AqsSimulateTest, GmshMeshWithDefaultActuationStaysAtRest) {
  testing::TempDir dir;
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadTetMesh(DataPath("test_meshes/blob.msh"), &mesh, &error)) << error;
  ASSERT_TRUE(WriteVertexList(dir.File("fixed.txt"), {0, 1, 2, 3}, "", &error));
  const testing::CommandResult run = RunCommand(
      Simulate("--mesh=" + DataPath("test_meshes/blob.msh") + " --fixed=" + dir.File("fixed.txt") +
               " --output=" + dir.File("x.mesh")));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  TetMesh x;
  ASSERT_TRUE(ReadTetMeshFile(dir.File("x.mesh"), &x, &error)) << error;
  EXPECT_LT((x.vertices - mesh.vertices).cwiseAbs().maxCoeff(), 1e-12);
}

// A 10-node tet is read by its corners; its mid-edge nodes stay vertices that no element
// uses, which have no stiffness: refused, naming the first, where the same tet with 4
// nodes solves.
TEST(AqsSimulateTest, VerticesOfNoElementAreRefused) {
  testing::TempDir dir;
  auto write = [&](const std::string& name, bool ten_nodes) {
    std::ofstream msh(dir.File(name));
    msh << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n"
        << (ten_nodes ? 10 : 4) << "\n"
        << "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
    if (ten_nodes) {
      msh << "5 0.5 0 0\n6 0.5 0.5 0\n7 0 0.5 0\n8 0 0 0.5\n9 0 0.5 0.5\n10 0.5 0 0.5\n";
    }
    msh << "$EndNodes\n$Elements\n1\n"
        << (ten_nodes ? "1 11 0 1 2 3 4 5 6 7 8 10 9\n" : "1 4 0 1 2 3 4\n") << "$EndElements\n";
  };
  write("four.msh", false);
  write("ten.msh", true);
  std::string error;
  ASSERT_TRUE(WriteVertexList(dir.File("fixed.txt"), {0, 1, 2}, "", &error)) << error;
  const std::string flags = " --fixed=" + dir.File("fixed.txt") + " --output=" + dir.File("x.mesh");
  const testing::CommandResult four =
      RunCommand(Simulate("--mesh=" + dir.File("four.msh") + flags));
  EXPECT_EQ(four.exit_code, 0) << four.output;
  const testing::CommandResult ten = RunCommand(Simulate("--mesh=" + dir.File("ten.msh") + flags));
  EXPECT_EQ(ten.exit_code, 1) << ten.output;
  EXPECT_NE(ten.output.find("ten.msh: vertex 4 (0-based) is used by no element"), std::string::npos)
      << ten.output;
}

// A file named like an option field (`mu` is the options' name for --mu), given by a
// relative path, is named as it is, with its line: the flag names replace option fields
// only, never the start of a path ("mu.txt:3:" had become "--mu.txt:3:").
TEST(AqsSimulateTest, FilesNamedLikeAnOptionKeepTheirNameAndLine) {
  testing::TempDir dir;
  dir.Write("mu.txt", "# stiffness per element\n\nabc\n");
  std::string values = "# stiffness per element\n\n";
  for (int e = 0; e < 7838; ++e) values += e == 2 ? "0\n" : "1\n";
  dir.Write("mu", values);
  const std::string flags = " --mesh=" + DataPath("examples/finger/finger.msh") +
                            " --fixed=" + DataPath("examples/finger/fixed.txt") +
                            " --output=x.mesh";
  const testing::CommandResult text =
      RunCommand("cd " + dir.path() + " && " + Simulate("--mu_per_element=mu.txt" + flags));
  EXPECT_EQ(text.exit_code, 1) << text.output;
  EXPECT_NE(text.output.find("error: mu.txt:3: "), std::string::npos) << text.output;
  const testing::CommandResult zero =
      RunCommand("cd " + dir.path() + " && " + Simulate("--mu_per_element=mu" + flags));
  EXPECT_EQ(zero.exit_code, 1) << zero.output;
  EXPECT_NE(zero.output.find("error: mu:5: the value for element 2 is 0"), std::string::npos)
      << zero.output;
  // The option's own message names the flag, whatever files are where the app runs.
  const testing::CommandResult flag =
      RunCommand("cd " + dir.path() + " && " + Simulate("--mu=-1" + flags));
  EXPECT_EQ(flag.exit_code, 1) << flag.output;
  EXPECT_NE(flag.output.find("error: --mu must be finite and > 0 (is -1)"), std::string::npos)
      << flag.output;
}

struct BadInputCase {
  std::string name;
  std::string flags;      // {dir} and {finger} are replaced
  int exit_code;
  std::string message;    // expected in the output
};

void PrintTo(const BadInputCase& c, std::ostream* out) { *out << c.name; }

class AqsSimulateBadInputTest : public ::testing::TestWithParam<BadInputCase> {};

TEST_P(AqsSimulateBadInputTest, FailsClearly) {
  testing::TempDir dir;
  dir.Write("short_actuation.txt", "1 1 1 0 0 0\n");
  dir.Write("bad_fixed.txt", "0\n1\n99999\n");
  dir.Write("far_fixed.txt", "0\n1 1e200 0 0\n");
  dir.Write("broken.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n");
  std::string flags = GetParam().flags;
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"{dir}", dir.path() + "/"},
        std::pair<std::string, std::string>{"{finger}", DataPath("examples/finger/")}}) {
    for (size_t pos; (pos = flags.find(key)) != std::string::npos;) flags.replace(pos, key.size(), value);
  }
  const testing::CommandResult run = RunCommand(Simulate(flags));
  EXPECT_EQ(run.exit_code, GetParam().exit_code) << run.output;
  EXPECT_NE(run.output.find(GetParam().message), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("Check failed"), std::string::npos) << "no crash: " << run.output;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, AqsSimulateBadInputTest,
    ::testing::Values(
        BadInputCase{"NoMesh", "--output={dir}x.mesh", 1, "no mesh given (--mesh)"},
        BadInputCase{"NoOutput", "--mesh={finger}finger.msh", 1, "no output given"},
        BadInputCase{"UnknownOutput", "--mesh={finger}finger.msh --output={dir}x.stl", 1,
                     "unknown output extension"},
        BadInputCase{"MissingMeshFile", "--mesh={dir}nope.mesh --output={dir}x.mesh", 1,
                     "nope.mesh: cannot open file"},
        BadInputCase{"TruncatedMesh", "--mesh={dir}broken.mesh --output={dir}x.mesh", 1,
                     "broken.mesh:"},
        BadInputCase{"ShortActuation",
                     "--mesh={finger}finger.msh --actuation={dir}short_actuation.txt "
                     "--output={dir}x.mesh",
                     1, "1 sxx syy szz sxy sxz syz lines for a mesh of 7838 elements"},
        BadInputCase{"FixedOutOfRange",
                     "--mesh={finger}finger.msh --fixed={dir}bad_fixed.txt --output={dir}x.mesh",
                     1, "bad_fixed.txt:3: vertex index 99999 is outside"},
        // A prescribed position far from the mesh: named at its line (the solve overflowed
        // and the message blamed an output field).
        BadInputCase{"FixedFarAway",
                     "--mesh={finger}finger.msh --fixed={dir}far_fixed.txt --output={dir}x.mesh",
                     1, "far_fixed.txt:2: the position of vertex 1: point 0 (1e+200 0 0) is"},
        BadInputCase{"GradientWithoutLoss",
                     "--mesh={finger}finger.msh --output={dir}x.mesh --gradient={dir}g.txt", 1,
                     "--gradient needs --loss_target"},
        BadInputCase{"NegativeMu", "--mesh={finger}finger.msh --output={dir}x.mesh --mu=-1", 1,
                     "--mu must be finite and > 0 (is -1)"},
        BadInputCase{"StrayArgument", "--mesh={finger}finger.msh stray --output={dir}x.mesh", 1,
                     "unexpected argument 'stray'"},
        BadInputCase{"NotConverged",
                     "--mesh={finger}finger.msh --fixed={finger}fixed.txt "
                     "--actuation={finger}actuation.txt --output={dir}x.mesh "
                     "--max_iterations=1 --newton_relative_force=0 --solver=lm",
                     2, "NOT CONVERGED"},
        BadInputCase{"NotConvergedNewton",
                     "--mesh={finger}finger.msh --fixed={finger}fixed.txt "
                     "--actuation={finger}actuation.txt --output={dir}x.mesh "
                     "--max_iterations=1 --tolerance=1e-12",
                     2, "NOT CONVERGED"},
        BadInputCase{"BadSolver",
                     "--mesh={finger}finger.msh --fixed={finger}fixed.txt --output={dir}x.mesh "
                     "--solver=gauss",
                     1, "--solver must be 'newton' or 'lm'"},
        BadInputCase{"FreeBodyNewton",
                     "--mesh={finger}finger.msh --output={dir}x.mesh --actuation={finger}actuation.txt",
                     1, "no fixed vertices (--fixed)"},
        BadInputCase{"FreeBodyGradient",
                     "--mesh={finger}finger.msh --output={dir}x.mesh --loss_target={finger}finger.msh"
                     " --gradient={dir}g.txt --solver=lm",
                     3, "free body"}),
    [](const ::testing::TestParamInfo<BadInputCase>& info) { return info.param.name; });

}  // namespace
}  // namespace aqs
