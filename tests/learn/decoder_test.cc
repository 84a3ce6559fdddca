#include "learn/decoder.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/fault_kill.h"
#include "testing/finite_difference.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

Eigen::MatrixXd RandomMatrix(int rows, int cols, double stddev, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, stddev);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(*rng);
  return m;
}

Eigen::Map<const Eigen::VectorXd> Flat(const Eigen::MatrixXd& m) {
  return Eigen::Map<const Eigen::VectorXd>(m.data(), m.size());
}

Eigen::Map<const Eigen::VectorXd> Flat(const ActuationMatrix& m) {
  return Eigen::Map<const Eigen::VectorXd>(m.data(), m.size());
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// A small decoder on a 72-element bar: a 4 x 3 x 3 grid (36 nodes) or one node per
// element, latent_dim 3, hidden {6, 5}.
class DecoderTest : public ::testing::TestWithParam<bool> {
 protected:
  DecoderTest() : mesh_(testing::BarMesh(3, 2, 2, 0.5)) {}

  bool per_element() const { return GetParam(); }

  ActuationDecoder MakeDecoder(Activation activation = Activation::kTanh,
                               bool linear_skip = false, bool anchored = false,
                               double output_scale = 0.1) const {
    GridActuationFieldOptions options;
    options.node_spacing = 0.6;
    options.per_element = per_element();
    DecoderSpec spec;
    spec.latent_dim = 3;
    spec.hidden_dims = {6, 5};
    spec.activation = activation;
    spec.linear_skip = linear_skip;
    spec.anchored = anchored;
    spec.output_scale = output_scale;
    return ActuationDecoder(spec, GridActuationField(mesh_, options));
  }

  TetMesh mesh_;
};

// L = sum_p 1/2 |a_p - target_p|^2 over a batch, for gradient checks.
struct QuadraticLoss {
  std::vector<ActuationMatrix> targets;

  double Value(const std::vector<ActuationMatrix>& a) const {
    double sum = 0.0;
    for (size_t p = 0; p < a.size(); ++p) sum += 0.5 * (a[p] - targets[p]).squaredNorm();
    return sum;
  }
  std::vector<ActuationMatrix> Gradient(const std::vector<ActuationMatrix>& a) const {
    std::vector<ActuationMatrix> g(a.size());
    for (size_t p = 0; p < a.size(); ++p) g[p] = a[p] - targets[p];
    return g;
  }
};

// Saves `params` of `decoder` to `path` and reads the file back.
void SaveAndLoad(const ActuationDecoder& decoder, const Eigen::VectorXd& params,
                 const std::string& path, DecoderSpec* spec, GridFieldDescription* field,
                 Eigen::VectorXd* loaded) {
  std::string error;
  ASSERT_TRUE(SaveDecoder(path, decoder.spec(), decoder.field().description(), params, &error))
      << error;
  ASSERT_TRUE(LoadDecoder(path, spec, field, loaded, &error)) << error;
}

QuadraticLoss RandomLoss(int num_poses, int num_elements, std::mt19937* rng) {
  QuadraticLoss loss;
  for (int p = 0; p < num_poses; ++p) {
    loss.targets.push_back(testing::RandomActuation(num_elements, 0.3, rng));
  }
  return loss;
}

TEST_P(DecoderTest, ShapesAndParameterCount) {
  const ActuationDecoder decoder = MakeDecoder();
  EXPECT_EQ(decoder.num_nodes(), per_element() ? 72 : 36);
  EXPECT_EQ(decoder.num_elements(), 72);
  EXPECT_EQ(decoder.latent_dim(), 3);
  EXPECT_EQ(decoder.mlp().output_dim(), 6 * decoder.num_nodes());
  EXPECT_EQ(decoder.num_parameters(), 6 * 4 + 5 * 7 + 6 * decoder.num_nodes() * 6);
}

TEST_P(DecoderTest, ParameterGradientMatchesFiniteDifferences) {
  for (Activation activation : {Activation::kElu, Activation::kTanh, Activation::kSoftplus}) {
    SCOPED_TRACE(ActivationName(activation));
    const ActuationDecoder decoder = MakeDecoder(activation);
    std::mt19937 rng(31);
    const Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
    const Eigen::MatrixXd latents = RandomMatrix(3, 2, 1.0, &rng);
    const QuadraticLoss loss = RandomLoss(2, decoder.num_elements(), &rng);
    DecoderWorkspace workspace;
    std::vector<ActuationMatrix> a;
    decoder.DecodeBatch(params.data(), latents, &a, &workspace);
    ASSERT_EQ(a.size(), 2u);
    Eigen::VectorXd gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
    decoder.Backward(params.data(), workspace, loss.Gradient(a), gradient.data(), nullptr);
    auto value = [&](const Eigen::VectorXd& p) {
      DecoderWorkspace w;
      std::vector<ActuationMatrix> decoded;
      decoder.DecodeBatch(p.data(), latents, &decoded, &w);
      return loss.Value(decoded);
    };
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(value, params, 1e-4);
    EXPECT_LT(testing::RelativeError(gradient, numeric), 1e-8);
    EXPECT_GT(numeric.norm(), 1e-2);
  }
}

TEST_P(DecoderTest, LatentGradientMatchesFiniteDifferences) {
  const ActuationDecoder decoder = MakeDecoder(Activation::kElu);
  std::mt19937 rng(32);
  const Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
  const Eigen::MatrixXd latents = RandomMatrix(3, 3, 1.0, &rng);
  const QuadraticLoss loss = RandomLoss(3, decoder.num_elements(), &rng);
  DecoderWorkspace workspace;
  std::vector<ActuationMatrix> a;
  decoder.DecodeBatch(params.data(), latents, &a, &workspace);
  Eigen::VectorXd param_gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
  Eigen::MatrixXd latent_gradient;
  decoder.Backward(params.data(), workspace, loss.Gradient(a), param_gradient.data(),
                   &latent_gradient);
  ASSERT_EQ(latent_gradient.rows(), 3);
  ASSERT_EQ(latent_gradient.cols(), 3);
  auto value = [&](const Eigen::VectorXd& flat) {
    DecoderWorkspace w;
    std::vector<ActuationMatrix> decoded;
    decoder.DecodeBatch(params.data(), Eigen::Map<const Eigen::MatrixXd>(flat.data(), 3, 3),
                        &decoded, &w);
    return loss.Value(decoded);
  };
  const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(value, Flat(latents), 1e-4);
  EXPECT_LT(testing::RelativeError(Flat(latent_gradient), numeric), 1e-8);
  EXPECT_GT(numeric.norm(), 1e-2);
}

TEST_P(DecoderTest, ActuationJacobianMatchesFiniteDifferences) {
  const ActuationDecoder decoder = MakeDecoder(Activation::kSoftplus);
  std::mt19937 rng(33);
  const Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
  const Eigen::VectorXd z = RandomMatrix(3, 1, 1.0, &rng);
  ActuationMatrix a_at_z;
  const Eigen::MatrixXd jacobian = decoder.ActuationJacobian(params.data(), z, &a_at_z);
  ASSERT_EQ(jacobian.rows(), 6 * decoder.num_elements());
  ASSERT_EQ(jacobian.cols(), 3);
  auto decode = [&](const Eigen::VectorXd& latent) {
    DecoderWorkspace w;
    ActuationMatrix a;
    decoder.Decode(params.data(), latent, &a, &w);
    return Eigen::VectorXd(Flat(a));
  };
  const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(decode, z, 1e-4);
  EXPECT_LT(testing::RelativeError(jacobian, numeric), 1e-9);
  EXPECT_GT(numeric.norm(), 1e-2);
  EXPECT_LT(testing::RelativeError(Flat(a_at_z), decode(z)), 1e-15);
  // The same Jacobian through reverse mode: row r of J is the latent gradient of a_r.
  DecoderWorkspace workspace;
  ActuationMatrix a;
  decoder.Decode(params.data(), z, &a, &workspace);
  const ActuationMatrix probe = RandomMatrix(6, decoder.num_elements(), 1.0, &rng);
  Eigen::VectorXd param_gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
  Eigen::MatrixXd latent_gradient;
  decoder.Backward(params.data(), workspace, probe, param_gradient.data(), &latent_gradient);
  EXPECT_LT(testing::RelativeError(latent_gradient, jacobian.transpose() * Flat(probe)), 1e-12);
}

// a(z) = I + field(s mlp(z)) with s = output_scale: by formula, from the network and the
// field called directly; a decoder with twice the scale deviates from I twice as much,
// and its Jacobian and both reverse-mode gradients are twice as large (a decoder that
// ignored s, or applied it twice, passes every finite-difference test).
TEST_P(DecoderTest, OutputScaleMultipliesTheNetworksOutputsBeforeTheField) {
  const ActuationDecoder decoder = MakeDecoder(Activation::kSoftplus, false, false, 0.13);
  const ActuationDecoder doubled = MakeDecoder(Activation::kSoftplus, false, false, 0.26);
  std::mt19937 rng(36);
  const Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
  const Eigen::VectorXd z = RandomMatrix(3, 1, 1.0, &rng);
  Eigen::MatrixXd outputs;
  MlpWorkspace mlp_workspace;
  decoder.mlp().Forward(params.data(), z, &outputs, &mlp_workspace);
  const NodeValueMatrix node_values =
      0.13 * Eigen::Map<const NodeValueMatrix>(outputs.data(), 6, decoder.num_nodes());
  ActuationMatrix expected;
  decoder.field().Apply(node_values, &expected);

  DecoderWorkspace workspace, doubled_workspace;
  ActuationMatrix a, a_doubled;
  decoder.Decode(params.data(), z, &a, &workspace);
  doubled.Decode(params.data(), z, &a_doubled, &doubled_workspace);
  EXPECT_LT(testing::RelativeError(a, expected), 1e-14);
  const ActuationMatrix identity = IdentityActuations(decoder.num_elements());
  EXPECT_GT((a - identity).norm(), 1e-2);
  EXPECT_LT(testing::RelativeError(a_doubled - identity, 2.0 * (a - identity)), 1e-13);

  const Eigen::MatrixXd jacobian = decoder.ActuationJacobian(params.data(), z, nullptr);
  EXPECT_LT(testing::RelativeError(doubled.ActuationJacobian(params.data(), z, nullptr),
                                   2.0 * jacobian),
            1e-13);
  const ActuationMatrix probe = RandomMatrix(6, decoder.num_elements(), 1.0, &rng);
  Eigen::VectorXd param_gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
  Eigen::VectorXd doubled_param_gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
  Eigen::MatrixXd latent_gradient, doubled_latent_gradient;
  decoder.Backward(params.data(), workspace, probe, param_gradient.data(), &latent_gradient);
  doubled.Backward(params.data(), doubled_workspace, probe, doubled_param_gradient.data(),
                   &doubled_latent_gradient);
  EXPECT_GT(param_gradient.norm(), 1e-2);
  EXPECT_LT(testing::RelativeError(doubled_param_gradient, 2.0 * param_gradient), 1e-13);
  EXPECT_LT(testing::RelativeError(doubled_latent_gradient, 2.0 * latent_gradient), 1e-13);
}

TEST_P(DecoderTest, SingleDecodeAndBackwardMatchTheBatch) {
  const ActuationDecoder decoder = MakeDecoder(Activation::kElu);
  std::mt19937 rng(34);
  const Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
  const Eigen::MatrixXd latents = RandomMatrix(3, 3, 1.0, &rng);
  const QuadraticLoss loss = RandomLoss(3, decoder.num_elements(), &rng);
  DecoderWorkspace batch_workspace;
  std::vector<ActuationMatrix> batch;
  decoder.DecodeBatch(params.data(), latents, &batch, &batch_workspace);
  const std::vector<ActuationMatrix> dl_da = loss.Gradient(batch);
  Eigen::VectorXd batch_gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
  Eigen::MatrixXd batch_latent_gradient;
  decoder.Backward(params.data(), batch_workspace, dl_da, batch_gradient.data(),
                   &batch_latent_gradient);
  Eigen::VectorXd summed = Eigen::VectorXd::Zero(decoder.num_parameters());
  for (int p = 0; p < 3; ++p) {
    DecoderWorkspace workspace;
    ActuationMatrix a;
    decoder.Decode(params.data(), latents.col(p), &a, &workspace);
    EXPECT_LT(testing::RelativeError(a, batch[p]), 1e-14);
    Eigen::MatrixXd latent_gradient;
    decoder.Backward(params.data(), workspace, dl_da[p], summed.data(), &latent_gradient);
    EXPECT_LT(testing::RelativeError(latent_gradient, batch_latent_gradient.col(p)), 1e-13);
  }
  EXPECT_LT(testing::RelativeError(summed, batch_gradient), 1e-13);
}

TEST_P(DecoderTest, InitialActuationsAreCloseToIdentity) {
  const ActuationDecoder decoder = MakeDecoder(Activation::kElu);
  Eigen::VectorXd params(decoder.num_parameters());
  decoder.InitializeParameters(1, params.data());
  std::mt19937 rng(35);
  DecoderWorkspace workspace;
  ActuationMatrix a;
  decoder.Decode(params.data(), RandomMatrix(3, 1, 1.0, &rng), &a, &workspace);
  const double deviation = (a - IdentityActuations(decoder.num_elements())).cwiseAbs().maxCoeff();
  EXPECT_GT(deviation, 1e-4);
  EXPECT_LT(deviation, 0.1);
}

TEST_P(DecoderTest, SaveLoadRoundTripIsBitForBit) {
  const ActuationDecoder decoder = MakeDecoder(Activation::kSoftplus);
  std::mt19937 rng(36);
  // Values with long expansions, tiny and huge magnitudes.
  Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
  params[0] = 1.0 / 3.0;
  params[1] = -2.2250738585072014e-308;
  params[2] = 1.7976931348623157e308;
  params[3] = 4.9406564584124654e-324;
  testing::TempDir dir;
  const std::string path = dir.File("decoder.txt");
  DecoderSpec spec;
  GridFieldDescription field;
  Eigen::VectorXd loaded;
  ASSERT_NO_FATAL_FAILURE(SaveAndLoad(decoder, params, path, &spec, &field, &loaded));
  ASSERT_EQ(loaded.size(), params.size());
  EXPECT_EQ(std::memcmp(loaded.data(), params.data(), sizeof(double) * params.size()), 0);
  EXPECT_EQ(spec.latent_dim, decoder.spec().latent_dim);
  EXPECT_EQ(spec.hidden_dims, decoder.spec().hidden_dims);
  EXPECT_EQ(spec.activation, decoder.spec().activation);
  EXPECT_EQ(spec.output_scale, decoder.spec().output_scale);
  const GridFieldDescription& original = decoder.field().description();
  EXPECT_EQ(field.per_element, original.per_element);
  EXPECT_EQ(field.num_elements, original.num_elements);
  EXPECT_EQ(field.num_nodes(), original.num_nodes());
  if (!per_element()) {
    EXPECT_EQ(field.origin, original.origin);
    EXPECT_EQ(field.spacing, original.spacing);
    EXPECT_EQ(field.grid_dims, original.grid_dims);
    EXPECT_EQ(field.nodes, original.nodes);
  }
  // Saving again gives the same file; the rebuilt decoder decodes identically.
  const std::string again = dir.File("again.txt");
  std::string error;
  ASSERT_TRUE(SaveDecoder(again, spec, field, loaded, &error)) << error;
  EXPECT_EQ(ReadAll(again), ReadAll(path));
  GridActuationField rebuilt_field;
  ASSERT_TRUE(GridActuationField::FromDescription(mesh_, field, path, &rebuilt_field, &error))
      << error;
  const ActuationDecoder rebuilt(spec, std::move(rebuilt_field));
  params.head(4).setConstant(0.1);
  loaded.head(4).setConstant(0.1);
  const Eigen::VectorXd z = RandomMatrix(3, 1, 1.0, &rng);
  DecoderWorkspace w1, w2;
  ActuationMatrix a1, a2;
  decoder.Decode(params.data(), z, &a1, &w1);
  rebuilt.Decode(loaded.data(), z, &a2, &w2);
  EXPECT_EQ(a1, a2);
}

// The linear skip, plain and anchored at the origin (the demo's decoder form): latent
// Jacobian and parameter gradient (the skip weights and, anchored, the mlp(0) term
// included) against central differences; anchored, z = 0 decodes to the identity for
// any parameters; the file keeps both flags and the weights.
TEST_P(DecoderTest, LinearSkipJacobianMatchesFiniteDifferencesAndRoundTrips) {
  for (const bool anchored : {false, true}) {
    SCOPED_TRACE(anchored ? "anchored" : "plain");
    const ActuationDecoder decoder = MakeDecoder(Activation::kElu, /*linear_skip=*/true, anchored);
    EXPECT_EQ(decoder.num_parameters(),
              6 * 4 + 5 * 7 + 6 * decoder.num_nodes() * 6 + 6 * decoder.num_nodes() * 3);
    std::mt19937 rng(anchored ? 38 : 37);
    const Eigen::VectorXd params = RandomMatrix(decoder.num_parameters(), 1, 0.5, &rng);
    const Eigen::VectorXd z = RandomMatrix(3, 1, 1.0, &rng);
    auto decode = [&](const Eigen::VectorXd& latent) {
      DecoderWorkspace w;
      ActuationMatrix a;
      decoder.Decode(params.data(), latent, &a, &w);
      return Eigen::VectorXd(Flat(a));
    };
    const Eigen::MatrixXd jacobian = decoder.ActuationJacobian(params.data(), z);
    EXPECT_LT(testing::RelativeError(jacobian, testing::CentralDifferenceJacobian(decode, z, 1e-4)),
              1e-9);
    const Eigen::VectorXd at_origin = decode(Eigen::VectorXd::Zero(3));
    const Eigen::VectorXd identity = Flat(IdentityActuations(decoder.num_elements()));
    if (anchored) {
      EXPECT_LT((at_origin - identity).cwiseAbs().maxCoeff(), 1e-15);
    } else {
      EXPECT_GT((at_origin - identity).cwiseAbs().maxCoeff(), 1e-3);
    }
    // Parameter gradient of L = <probe, a(z)>, the skip weights included.
    const ActuationMatrix probe = RandomMatrix(6, decoder.num_elements(), 1.0, &rng);
    DecoderWorkspace workspace;
    ActuationMatrix a;
    decoder.Decode(params.data(), z, &a, &workspace);
    Eigen::VectorXd gradient = Eigen::VectorXd::Zero(decoder.num_parameters());
    decoder.Backward(params.data(), workspace, probe, gradient.data(), nullptr);
    auto loss = [&](const Eigen::VectorXd& p) {
      DecoderWorkspace w;
      ActuationMatrix decoded;
      decoder.Decode(p.data(), z, &decoded, &w);
      return Flat(decoded).dot(Flat(probe));
    };
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(loss, params, 1e-4);
    EXPECT_LT(testing::RelativeError(gradient, numeric), 1e-9);
    const Eigen::Index skip = decoder.mlp().skip_offset();
    EXPECT_GT(numeric.tail(decoder.num_parameters() - skip).norm(), 1e-2);
    // The file keeps the flags and the weights.
    testing::TempDir dir;
    const std::string path = dir.File("decoder.txt");
    DecoderSpec spec;
    GridFieldDescription field;
    Eigen::VectorXd loaded;
    ASSERT_NO_FATAL_FAILURE(SaveAndLoad(decoder, params, path, &spec, &field, &loaded));
    EXPECT_TRUE(spec.linear_skip);
    EXPECT_EQ(spec.anchored, anchored);
    EXPECT_EQ(std::memcmp(loaded.data(), params.data(), sizeof(double) * params.size()), 0);
  }
}

INSTANTIATE_TEST_SUITE_P(GridAndPerElement, DecoderTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return std::string(info.param ? "PerElement" : "Grid");
                         });

// Lines of a valid decoder file, with one line changed, must fail naming that line.
class MalformedDecoderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const TetMesh mesh = testing::BarMesh(2, 1, 1, 0.5);
    GridActuationFieldOptions options;
    options.node_spacing = 0.4;
    DecoderSpec spec;
    spec.latent_dim = 2;
    spec.hidden_dims = {3};
    const ActuationDecoder decoder(spec, GridActuationField(mesh, options));
    Eigen::VectorXd params(decoder.num_parameters());
    decoder.InitializeParameters(2, params.data());
    const std::string path = dir_.File("valid.txt");
    std::string error;
    ASSERT_TRUE(SaveDecoder(path, spec, decoder.field().description(), params, &error)) << error;
    std::istringstream in(ReadAll(path));
    std::string line;
    while (std::getline(in, line)) lines_.push_back(line);
  }

  // 1-based number of the first line that starts with `prefix`.
  int LineStartingWith(const std::string& prefix) const {
    for (size_t i = 0; i < lines_.size(); ++i) {
      if (lines_[i].compare(0, prefix.size(), prefix) == 0) return static_cast<int>(i) + 1;
    }
    ADD_FAILURE() << "no line starts with " << prefix;
    return 1;
  }

  // Writes the lines with line `number` (1-based) replaced by `replacement` (or removed
  // if `remove`) and expects LoadDecoder to fail with "path:line_expected" and `what`.
  void ExpectFailure(int number, const std::string& replacement, int line_expected,
                     const std::string& what, bool remove = false) {
    std::string content;
    for (size_t i = 0; i < lines_.size(); ++i) {
      if (static_cast<int>(i) + 1 == number) {
        if (remove) continue;
        content += replacement + "\n";
      } else {
        content += lines_[i] + "\n";
      }
    }
    const std::string path = dir_.Write("case" + std::to_string(++case_count_) + ".txt", content);
    DecoderSpec spec;
    GridFieldDescription field;
    Eigen::VectorXd params;
    std::string error;
    EXPECT_FALSE(LoadDecoder(path, &spec, &field, &params, &error))
        << "line " << number << " -> '" << replacement << "'";
    EXPECT_NE(error.find(path + ":" + std::to_string(line_expected) + ":"), std::string::npos)
        << error;
    EXPECT_NE(error.find(what), std::string::npos) << error;
  }

  testing::TempDir dir_;
  std::vector<std::string> lines_;
  int case_count_ = 0;
};

TEST_F(MalformedDecoderTest, ValidFileLoads) {
  const std::string path = dir_.File("valid.txt");
  DecoderSpec spec;
  GridFieldDescription field;
  Eigen::VectorXd params;
  std::string error;
  EXPECT_TRUE(LoadDecoder(path, &spec, &field, &params, &error)) << error;
}

TEST_F(MalformedDecoderTest, EachBrokenLineIsNamed) {
  int n = LineStartingWith("aqs_actuation_decoder");
  ExpectFailure(n, "aqs_decoder 1", n, "expected 'aqs_actuation_decoder'");
  ExpectFailure(n, "aqs_actuation_decoder 2", n, "version");
  n = LineStartingWith("latent_dim");
  ExpectFailure(n, "latent_dim 0", n, "latent_dim must be a positive integer");
  ExpectFailure(n, "latent_dim 2 3", n, "takes 1 value");
  n = LineStartingWith("hidden_dims");
  ExpectFailure(n, "hidden_dims 2 3", n, "followed by 2 widths");
  ExpectFailure(n, "hidden_dims 1 -3", n, "hidden width");
  n = LineStartingWith("activation");
  ExpectFailure(n, "activation relu", n, "unknown activation 'relu'");
  n = LineStartingWith("output_scale");
  ExpectFailure(n, "output_scale abc", n, "finite number");
  ExpectFailure(n, "output_scale -1", n, "positive");
  n = LineStartingWith("anchored");
  ExpectFailure(n, "anchored 2", n, "'anchored' takes 0 or 1");
  ExpectFailure(n, "linear_skip yes", n, "'linear_skip' takes 0 or 1");
  // A skip the parameters do not have: the count no longer matches.
  ExpectFailure(n, "linear_skip 1", LineStartingWith("num_parameters"),
                "does not match the layer sizes");
  n = LineStartingWith("field");
  ExpectFailure(n, "field octree", n, "unknown field");
  n = LineStartingWith("num_elements");
  ExpectFailure(n, "num_elements x", n, "num_elements");
  n = LineStartingWith("origin");
  ExpectFailure(n, "origin 0 0", n, "takes 3 value");
  ExpectFailure(n, "origin 0 nan 0", n, "finite number");
  n = LineStartingWith("spacing");
  ExpectFailure(n, "spacing 0", n, "spacing must be positive");
  n = LineStartingWith("grid_dims");
  ExpectFailure(n, "grid_dims 1 2 2", n, "at least 2");
  n = LineStartingWith("num_nodes");
  ExpectFailure(n, "num_nodes 100000", n, "more than the grid holds");
  // Node lines follow num_nodes after one comment line.
  const int first_node = n + 2;
  ExpectFailure(first_node, "0 0 9", first_node, "grid coordinate '9'");
  ExpectFailure(first_node, "0 0", first_node, "expected 3 number(s)");
  ExpectFailure(first_node + 1, lines_[first_node - 1], first_node + 1, "out of order");
  n = LineStartingWith("num_parameters");
  ExpectFailure(n, "num_parameters 7", n, "does not match the layer sizes");
  // A parameter that is not a number, two on a line, a missing and an extra line.
  const int last = static_cast<int>(lines_.size());
  ExpectFailure(last, "0.5x", last, "parameter");
  ExpectFailure(last, "0.5 0.5", last, "expected 1 number(s)");
  ExpectFailure(last, "", last - 1, "unexpected end of file", /*remove=*/true);
  ExpectFailure(last, lines_[last - 1] + "\n0.25", last + 1, "unexpected content");
  // A keyword out of order.
  n = LineStartingWith("activation");
  ExpectFailure(n, "output_scale 0.1", n, "expected 'activation'");
}

// A damaged count (hidden widths and num_parameters that agree, about 8 GB of
// parameters, in a file that ends after them) fails naming the line where the file ends,
// in a process that cannot allocate 1 GB more: the reader grows the parameters as it
// reads them (it had allocated them all at once, std::bad_alloc). The same for the
// control grid's node count.
TEST_F(MalformedDecoderTest, HugeCountsInASmallFileDoNotAllocateThem) {
  // The parameter count for hidden width w, from the message that names it.
  auto parameters_for = [&](int64_t w) -> int64_t {
    std::string content;
    for (const std::string& line : lines_) {
      content += (line.rfind("hidden_dims", 0) == 0 ? "hidden_dims 1 " + std::to_string(w)
                                                     : line) + "\n";
    }
    const std::string path = dir_.Write("count.txt", content);
    DecoderSpec spec;
    GridFieldDescription field;
    Eigen::VectorXd params;
    std::string error;
    EXPECT_FALSE(LoadDecoder(path, &spec, &field, &params, &error));
    const size_t at = error.find("which need ");
    return at == std::string::npos ? -1 : std::stoll(error.substr(at + 11));
  };
  const int64_t base = parameters_for(1), step = parameters_for(2) - base;
  ASSERT_GT(step, 0);
  const int64_t width = 1 + (1000000000 - base) / step;  // about 1e9 parameters
  std::string huge;
  for (const std::string& line : lines_) {
    if (line.rfind("hidden_dims", 0) == 0) {
      huge += "hidden_dims 1 " + std::to_string(width) + "\n";
    } else if (line.rfind("num_parameters", 0) == 0) {
      huge += "num_parameters " + std::to_string(base + (width - 1) * step) + "\n0.5\n";
      break;
    } else {
      huge += line + "\n";
    }
  }
  const std::string huge_parameters = dir_.Write("huge_parameters.txt", huge);
  std::string nodes;
  for (const std::string& line : lines_) {
    if (line.rfind("grid_dims", 0) == 0) {
      nodes += "grid_dims 1000 1000 1000\n";
    } else if (line.rfind("num_nodes", 0) == 0) {
      nodes += "num_nodes 300000000\n0 0 0\n";
      break;
    } else {
      nodes += line + "\n";
    }
  }
  const std::string huge_nodes = dir_.Write("huge_nodes.txt", nodes);
  for (const std::string& path : {huge_parameters, huge_nodes}) {
    SCOPED_TRACE(path);
    const std::string outcome = testing::RunInChildKilledAt(-1, [&]() {
      if (!testing::LimitAddressSpaceToCurrentPlus(1L << 30)) return false;
      try {
        DecoderSpec spec;
        GridFieldDescription field;
        Eigen::VectorXd params;
        std::string error;
        const bool loaded = LoadDecoder(path, &spec, &field, &params, &error);
        std::fprintf(stderr, "error: '%s'\n", error.c_str());
        return !loaded && error.find("unexpected end of file") != std::string::npos;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "exception: %s\n", e.what());
        return false;
      }
    });
    EXPECT_EQ(outcome, "exit 0");
  }
}

TEST_F(MalformedDecoderTest, MissingFileIsNamed) {
  const std::string path = dir_.File("missing.txt");
  DecoderSpec spec;
  GridFieldDescription field;
  Eigen::VectorXd params;
  std::string error;
  EXPECT_FALSE(LoadDecoder(path, &spec, &field, &params, &error));
  EXPECT_NE(error.find(path), std::string::npos) << error;
}

TEST(DecoderMemoryTest, CountsParametersFieldAndJacobian) {
  const TetMesh mesh = testing::BarMesh(3, 2, 2, 0.5);
  GridActuationFieldOptions options;
  options.node_spacing = 0.6;
  const ActuationDecoder decoder(DecoderSpec(), GridActuationField(mesh, options));
  const DecoderMemory memory = DecoderMemoryBytes(decoder.spec(), decoder.field().description(), 4);
  EXPECT_EQ(memory.parameters, 8.0 * decoder.num_parameters());
  EXPECT_EQ(memory.field, 96.0 * mesh.num_tets());
  EXPECT_EQ(memory.actuations, 2.0 * 4 * 6 * 8.0 * mesh.num_tets());
  EXPECT_GE(memory.actuation_jacobian, 8.0 * 6 * mesh.num_tets() * 16);
  EXPECT_EQ(memory.total, memory.parameters + memory.field + memory.workspace +
                              memory.actuations + memory.actuation_jacobian);
  GridFieldDescription per_element;
  per_element.per_element = true;
  per_element.num_elements = mesh.num_tets();
  EXPECT_EQ(DecoderMemoryBytes(DecoderSpec(), per_element, 1).field, 0.0);
}

// The figures documented in learn/decoder.h, on the benchmark's 257,250-element lattice.
TEST(DecoderMemoryTest, DefaultConfigurationAt250KElements) {
  const TetMesh mesh = testing::BarMesh(35, 35, 35, 1.0);
  ASSERT_EQ(mesh.num_tets(), 257250);
  const GridActuationField field(mesh, GridActuationFieldOptions());
  const DecoderSpec spec;
  const Mlp mlp(DecoderMlpSpec(spec, field.num_nodes()));
  const DecoderMemory memory = DecoderMemoryBytes(spec, field.description(), 1);
  std::printf("250K elements: spacing %.3f, grid %d x %d x %d, %d nodes, %d outputs, "
              "%d parameters; MB: parameters %.2f, field %.2f, workspace %.3f, "
              "actuations %.2f, jacobian %.2f, total %.2f\n",
              field.description().spacing, field.description().grid_dims[0],
              field.description().grid_dims[1], field.description().grid_dims[2],
              field.num_nodes(), mlp.output_dim(), mlp.num_parameters(),
              memory.parameters / 1e6, memory.field / 1e6, memory.workspace / 1e6,
              memory.actuations / 1e6, memory.actuation_jacobian / 1e6, memory.total / 1e6);
  EXPECT_EQ(field.description().grid_dims, Eigen::Vector3i(8, 8, 8));
  EXPECT_EQ(field.num_nodes(), 512);
  EXPECT_EQ(mlp.num_parameters(), 414976);
  EXPECT_NEAR(memory.field / 1e6, 24.7, 0.05);
  EXPECT_NEAR(memory.actuation_jacobian / 1e6, 210.3, 0.05);
  GridFieldDescription per_element;
  per_element.per_element = true;
  per_element.num_elements = mesh.num_tets();
  const DecoderMemory dense = DecoderMemoryBytes(spec, per_element, 1);
  std::printf("per element: %.0f parameters, %.1f MB per parameter array\n",
              dense.parameters / 8.0, dense.parameters / 1e6);
  EXPECT_EQ(dense.parameters, 8.0 * 199130188);
}

}  // namespace
}  // namespace aqs
