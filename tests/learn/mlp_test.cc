#include "learn/mlp.h"

#include <cmath>
#include <ostream>
#include <random>
#include <tuple>
#include <string>

#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {

// Test names and failure messages show the activation's name.
void PrintTo(Activation activation, std::ostream* out) { *out << ActivationName(activation); }

namespace {

Eigen::MatrixXd RandomMatrix(int rows, int cols, double stddev, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, stddev);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(*rng);
  return m;
}

// Outputs of `mlp` for inputs, as a flat vector (column-major).
Eigen::VectorXd ForwardFlat(const Mlp& mlp, const Eigen::VectorXd& params,
                            const Eigen::MatrixXd& inputs) {
  MlpWorkspace workspace;
  Eigen::MatrixXd outputs;
  mlp.Forward(params.data(), inputs, &outputs, &workspace);
  return Eigen::Map<const Eigen::VectorXd>(outputs.data(), outputs.size());
}

// Every activation, plain and anchored at the origin (MlpSpec::zero_at_origin), with and
// without the linear skip (MlpSpec::linear_skip).
class MlpActivationTest
    : public ::testing::TestWithParam<std::tuple<Activation, bool, bool>> {
 protected:
  // Three layers with uneven widths, so that any mix-up of rows and columns shows.
  MlpSpec Spec() const {
    MlpSpec spec;
    spec.input_dim = 3;
    spec.hidden_dims = {5, 4};
    spec.output_dim = 7;
    spec.activation = std::get<0>(GetParam());
    spec.zero_at_origin = std::get<1>(GetParam());
    spec.linear_skip = std::get<2>(GetParam());
    return spec;
  }
};

TEST_P(MlpActivationTest, ParameterGradientMatchesFiniteDifferences) {
  const Mlp mlp(Spec());
  std::mt19937 rng(3);
  // Random parameters (not the initialization), biases included, of a size that puts
  // pre-activations on both sides of 0.
  const Eigen::VectorXd params = RandomMatrix(mlp.num_parameters(), 1, 0.7, &rng);
  const int batch = 4;
  const Eigen::MatrixXd inputs = RandomMatrix(mlp.input_dim(), batch, 1.0, &rng);
  const Eigen::MatrixXd weights = RandomMatrix(mlp.output_dim(), batch, 1.0, &rng);
  // L = sum(weights .* outputs), so dL/doutputs = weights.
  auto loss = [&](const Eigen::VectorXd& p) {
    return ForwardFlat(mlp, p, inputs).dot(
        Eigen::Map<const Eigen::VectorXd>(weights.data(), weights.size()));
  };
  MlpWorkspace workspace;
  Eigen::MatrixXd outputs;
  mlp.Forward(params.data(), inputs, &outputs, &workspace);
  // Backward accumulates: start from a non-zero array.
  const Eigen::VectorXd prior = Eigen::VectorXd::Constant(mlp.num_parameters(), 0.25);
  Eigen::VectorXd gradient = prior;
  mlp.Backward(params.data(), workspace, weights, gradient.data(), nullptr);
  const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(loss, params, 1e-4);
  EXPECT_LT(testing::RelativeError(gradient - prior, numeric), 1e-9);
  EXPECT_GT(numeric.norm(), 1e-2);
}

TEST_P(MlpActivationTest, InputGradientMatchesFiniteDifferences) {
  const Mlp mlp(Spec());
  std::mt19937 rng(4);
  const Eigen::VectorXd params = RandomMatrix(mlp.num_parameters(), 1, 0.7, &rng);
  const int batch = 3;
  const Eigen::MatrixXd inputs = RandomMatrix(mlp.input_dim(), batch, 1.0, &rng);
  const Eigen::MatrixXd weights = RandomMatrix(mlp.output_dim(), batch, 1.0, &rng);
  auto loss = [&](const Eigen::VectorXd& flat_inputs) {
    const Eigen::MatrixXd x = Eigen::Map<const Eigen::MatrixXd>(flat_inputs.data(),
                                                                mlp.input_dim(), batch);
    return ForwardFlat(mlp, params, x).dot(
        Eigen::Map<const Eigen::VectorXd>(weights.data(), weights.size()));
  };
  MlpWorkspace workspace;
  Eigen::MatrixXd outputs;
  mlp.Forward(params.data(), inputs, &outputs, &workspace);
  Eigen::VectorXd param_gradient = Eigen::VectorXd::Zero(mlp.num_parameters());
  Eigen::MatrixXd input_gradient;
  mlp.Backward(params.data(), workspace, weights, param_gradient.data(), &input_gradient);
  ASSERT_EQ(input_gradient.rows(), mlp.input_dim());
  ASSERT_EQ(input_gradient.cols(), batch);
  const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(
      loss, Eigen::Map<const Eigen::VectorXd>(inputs.data(), inputs.size()), 1e-4);
  EXPECT_LT(testing::RelativeError(
                Eigen::Map<const Eigen::VectorXd>(input_gradient.data(), input_gradient.size()),
                numeric),
            1e-9);
  EXPECT_GT(numeric.norm(), 1e-2);
}

TEST_P(MlpActivationTest, InputJacobianMatchesFiniteDifferences) {
  const Mlp mlp(Spec());
  std::mt19937 rng(5);
  const Eigen::VectorXd params = RandomMatrix(mlp.num_parameters(), 1, 0.7, &rng);
  const Eigen::VectorXd input = RandomMatrix(mlp.input_dim(), 1, 1.0, &rng);
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd output;
  mlp.InputJacobian(params.data(), input, &jacobian, &output);
  ASSERT_EQ(jacobian.rows(), mlp.output_dim());
  ASSERT_EQ(jacobian.cols(), mlp.input_dim());
  auto f = [&](const Eigen::VectorXd& x) { return ForwardFlat(mlp, params, x); };
  const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(f, input, 1e-4);
  EXPECT_LT(testing::RelativeError(jacobian, numeric), 1e-9);
  EXPECT_LT(testing::RelativeError(output, f(input)), 1e-15);
}

TEST_P(MlpActivationTest, BatchColumnsAreIndependentSamples) {
  const Mlp mlp(Spec());
  std::mt19937 rng(6);
  const Eigen::VectorXd params = RandomMatrix(mlp.num_parameters(), 1, 0.7, &rng);
  const Eigen::MatrixXd inputs = RandomMatrix(mlp.input_dim(), 5, 1.0, &rng);
  const Eigen::VectorXd batched = ForwardFlat(mlp, params, inputs);
  for (int s = 0; s < 5; ++s) {
    const Eigen::VectorXd single = ForwardFlat(mlp, params, inputs.col(s));
    EXPECT_LT(testing::RelativeError(batched.segment(s * mlp.output_dim(), mlp.output_dim()),
                                     single),
              1e-14);
  }
}

TEST_P(MlpActivationTest, AnchoredNetworksVanishAtTheOrigin) {
  const Mlp mlp(Spec());
  std::mt19937 rng(7);
  const Eigen::VectorXd params = RandomMatrix(mlp.num_parameters(), 1, 0.7, &rng);
  const Eigen::VectorXd at_origin = ForwardFlat(mlp, params, Eigen::VectorXd::Zero(mlp.input_dim()));
  if (mlp.spec().zero_at_origin) {
    EXPECT_EQ(at_origin.cwiseAbs().maxCoeff(), 0.0);
    // The output bias cancels: its gradient is zero.
    MlpWorkspace workspace;
    Eigen::MatrixXd outputs;
    const Eigen::MatrixXd inputs = RandomMatrix(mlp.input_dim(), 3, 1.0, &rng);
    mlp.Forward(params.data(), inputs, &outputs, &workspace);
    EXPECT_EQ(workspace.batch_size(), 3);
    Eigen::VectorXd gradient = Eigen::VectorXd::Zero(mlp.num_parameters());
    mlp.Backward(params.data(), workspace, RandomMatrix(mlp.output_dim(), 3, 1.0, &rng),
                 gradient.data(), nullptr);
    const int last = mlp.num_layers() - 1;
    EXPECT_LT(gradient.segment(mlp.bias_offset(last), mlp.output_dim()).cwiseAbs().maxCoeff(),
              1e-13);
  } else {
    EXPECT_GT(at_origin.norm(), 1e-3);
  }
}

INSTANTIATE_TEST_SUITE_P(AllActivations, MlpActivationTest,
                         ::testing::Combine(::testing::Values(Activation::kElu, Activation::kTanh,
                                                              Activation::kSoftplus),
                                            ::testing::Bool(), ::testing::Bool()),
                         [](const ::testing::TestParamInfo<std::tuple<Activation, bool, bool>>&
                                info) {
                           return ActivationName(std::get<0>(info.param)) +
                                  (std::get<1>(info.param) ? "_anchored" : "") +
                                  (std::get<2>(info.param) ? "_skip" : "");
                         });

TEST(MlpTest, LinearSkipAddsItsWeightsTimesTheInputAndStartsAtZero) {
  MlpSpec spec;
  spec.input_dim = 3;
  spec.hidden_dims = {5};
  spec.output_dim = 4;
  const Mlp plain(spec);
  spec.linear_skip = true;
  const Mlp skip(spec);
  ASSERT_EQ(skip.num_parameters(), plain.num_parameters() + 4 * 3);
  EXPECT_EQ(skip.skip_offset(), plain.num_parameters());
  std::mt19937 rng(9);
  Eigen::VectorXd params = RandomMatrix(skip.num_parameters(), 1, 0.7, &rng);
  const Eigen::MatrixXd inputs = RandomMatrix(3, 2, 1.0, &rng);
  const Eigen::Map<const Eigen::MatrixXd> w_s(params.data() + skip.skip_offset(), 4, 3);
  const Eigen::VectorXd expected =
      ForwardFlat(plain, params.head(plain.num_parameters()), inputs) +
      Eigen::Map<const Eigen::VectorXd>(Eigen::MatrixXd(w_s * inputs).data(), 8);
  EXPECT_LT(testing::RelativeError(ForwardFlat(skip, params, inputs), expected), 1e-14);
  skip.InitializeParameters(1, params.data());
  EXPECT_EQ(params.tail(12).cwiseAbs().maxCoeff(), 0.0);
}

TEST(MlpTest, ParameterLayoutIsWeightsColumnMajorThenBias) {
  MlpSpec spec;
  spec.input_dim = 2;
  spec.hidden_dims = {3};
  spec.output_dim = 2;
  const Mlp mlp(spec);
  ASSERT_EQ(mlp.num_layers(), 2);
  EXPECT_EQ(mlp.num_parameters(), 3 * 2 + 3 + 2 * 3 + 2);
  EXPECT_EQ(mlp.weight_offset(0), 0);
  EXPECT_EQ(mlp.bias_offset(0), 6);
  EXPECT_EQ(mlp.weight_offset(1), 9);
  EXPECT_EQ(mlp.bias_offset(1), 15);
  Eigen::VectorXd params(mlp.num_parameters());
  for (int i = 0; i < params.size(); ++i) params[i] = 0.1 * (i + 1);
  Eigen::Matrix<double, 3, 2> w0;
  w0 << 0.1, 0.4,
        0.2, 0.5,
        0.3, 0.6;
  const Eigen::Vector3d b0(0.7, 0.8, 0.9);
  Eigen::Matrix<double, 2, 3> w1;
  w1 << 1.0, 1.2, 1.4,
        1.1, 1.3, 1.5;
  const Eigen::Vector2d b1(1.6, 1.7);
  const Eigen::Vector2d x(0.5, -2.0);
  Eigen::Vector3d hidden = w0 * x + b0;
  for (int i = 0; i < 3; ++i) hidden[i] = hidden[i] > 0 ? hidden[i] : std::expm1(hidden[i]);
  const Eigen::Vector2d expected = w1 * hidden + b1;
  EXPECT_LT(testing::RelativeError(ForwardFlat(mlp, params, x), expected), 1e-14);
}

TEST(MlpTest, ActivationValuesIncludingLargeArguments) {
  // input -> one hidden unit (weight 1, bias 0) -> output (weight 1, bias 0): y = sigma(x).
  for (Activation activation : {Activation::kElu, Activation::kTanh, Activation::kSoftplus}) {
    SCOPED_TRACE(ActivationName(activation));
    MlpSpec spec;
    spec.input_dim = 1;
    spec.hidden_dims = {1};
    spec.output_dim = 1;
    spec.activation = activation;
    const Mlp mlp(spec);
    const Eigen::Vector4d params(1.0, 0.0, 1.0, 0.0);
    Eigen::MatrixXd x(1, 5);
    x << -1000.0, -1.0, 0.5, 3.0, 1000.0;
    const Eigen::VectorXd y = ForwardFlat(mlp, params, x);
    for (int i = 0; i < 5; ++i) {
      const double v = x(0, i);
      double expected = 0.0;
      switch (activation) {
        case Activation::kElu:
          expected = v > 0 ? v : std::exp(v) - 1.0;
          break;
        case Activation::kTanh:
          expected = std::tanh(v);
          break;
        case Activation::kSoftplus:
          expected = v > 30 ? v : std::log(1.0 + std::exp(v));
          break;
      }
      EXPECT_NEAR(y[i], expected, 1e-14 * std::max(1.0, std::abs(expected))) << "x = " << v;
    }
    // Derivatives at the extremes are the activation's limiting slopes: 1 (ELU, softplus)
    // or 0 (tanh) at +1000, and 0 at -1000.
    Eigen::MatrixXd jacobian;
    mlp.InputJacobian(params.data(), Eigen::VectorXd::Constant(1, 1000.0), &jacobian);
    ASSERT_EQ(jacobian.size(), 1);
    EXPECT_NEAR(jacobian(0, 0), activation == Activation::kTanh ? 0.0 : 1.0, 1e-12);
    mlp.InputJacobian(params.data(), Eigen::VectorXd::Constant(1, -1000.0), &jacobian);
    ASSERT_EQ(jacobian.size(), 1);
    EXPECT_NEAR(jacobian(0, 0), 0.0, 1e-12);
  }
}

TEST(MlpTest, NoHiddenLayersIsAffine) {
  MlpSpec spec;
  spec.input_dim = 4;
  spec.output_dim = 3;
  const Mlp mlp(spec);
  EXPECT_EQ(mlp.num_layers(), 1);
  std::mt19937 rng(7);
  const Eigen::VectorXd params = RandomMatrix(mlp.num_parameters(), 1, 1.0, &rng);
  const Eigen::MatrixXd inputs = RandomMatrix(4, 2, 1.0, &rng);
  const Eigen::Map<const Eigen::MatrixXd> w(params.data(), 3, 4);
  const Eigen::Map<const Eigen::VectorXd> b(params.data() + 12, 3);
  Eigen::MatrixXd expected = w * inputs;
  expected.colwise() += b;
  EXPECT_LT(testing::RelativeError(ForwardFlat(mlp, params, inputs),
                                   Eigen::Map<const Eigen::VectorXd>(expected.data(), 6)),
            1e-15);
  MlpWorkspace workspace;
  Eigen::MatrixXd outputs;
  mlp.Forward(params.data(), inputs, &outputs, &workspace);
  Eigen::VectorXd gradient = Eigen::VectorXd::Zero(mlp.num_parameters());
  Eigen::MatrixXd input_gradient;
  const Eigen::MatrixXd g = RandomMatrix(3, 2, 1.0, &rng);
  mlp.Backward(params.data(), workspace, g, gradient.data(), &input_gradient);
  EXPECT_LT(testing::RelativeError(input_gradient, w.transpose() * g), 1e-15);
  const Eigen::MatrixXd dw = g * inputs.transpose();
  EXPECT_LT(testing::RelativeError(gradient.head(12),
                                   Eigen::Map<const Eigen::VectorXd>(dw.data(), 12)),
            1e-15);
}

TEST(MlpTest, InitializationIsDeterministicWithZeroBiasesAndASmallOutputLayer) {
  MlpSpec spec;
  spec.input_dim = 16;
  spec.hidden_dims = {64, 64};
  spec.output_dim = 600;
  const Mlp mlp(spec);
  Eigen::VectorXd a(mlp.num_parameters()), b(mlp.num_parameters()), c(mlp.num_parameters());
  mlp.InitializeParameters(11, a.data());
  mlp.InitializeParameters(11, b.data());
  mlp.InitializeParameters(12, c.data());
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  for (int l = 0; l < mlp.num_layers(); ++l) {
    const int fan_out = mlp.widths()[l + 1];
    const int fan_in = mlp.widths()[l];
    EXPECT_EQ(a.segment(mlp.bias_offset(l), fan_out).norm(), 0.0) << "layer " << l;
    const Eigen::VectorXd w = a.segment(mlp.weight_offset(l), fan_out * fan_in);
    const double rms = std::sqrt(w.squaredNorm() / w.size());
    const double expected = l + 1 == mlp.num_layers() ? 0.1 / std::sqrt(fan_in)
                                                      : std::sqrt(2.0 / fan_in);
    EXPECT_NEAR(rms, expected, 0.1 * expected) << "layer " << l;
  }
  // Initial outputs are small for O(1) inputs.
  std::mt19937 rng(8);
  const Eigen::MatrixXd inputs = RandomMatrix(16, 8, 1.0, &rng);
  const Eigen::VectorXd outputs = ForwardFlat(mlp, a, inputs);
  const double rms = std::sqrt(outputs.squaredNorm() / outputs.size());
  EXPECT_GT(rms, 0.01);
  EXPECT_LT(rms, 0.5);
}

TEST(MlpTest, ActivationNamesRoundTrip) {
  for (Activation activation : {Activation::kElu, Activation::kTanh, Activation::kSoftplus}) {
    Activation parsed = Activation::kElu;
    ASSERT_TRUE(ActivationFromName(ActivationName(activation), &parsed));
    EXPECT_EQ(parsed, activation);
  }
  Activation parsed;
  EXPECT_FALSE(ActivationFromName("relu", &parsed));
}

}  // namespace
}  // namespace aqs
