#ifndef AQS_LEARN_MLP_H_
#define AQS_LEARN_MLP_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// Nonlinearity of the hidden layers (the output layer is always linear).
//   kElu:      x for x > 0, exp(x) - 1 otherwise (alpha = 1; continuously differentiable);
//   kTanh:     tanh(x);
//   kSoftplus: log(1 + exp(x)), evaluated without overflow.
enum class Activation { kElu, kTanh, kSoftplus };

// "elu", "tanh", "softplus" (the names used in decoder files).
std::string ActivationName(Activation activation);
// Inverse of ActivationName. Returns false for an unknown name.
bool ActivationFromName(const std::string& name, Activation* activation);

// Layer sizes of a multilayer perceptron: input_dim -> hidden_dims[0] -> ... ->
// hidden_dims.back() -> output_dim. hidden_dims may be empty (a single affine map).
struct MlpSpec {
  int input_dim = 0;
  std::vector<int> hidden_dims;
  int output_dim = 0;
  Activation activation = Activation::kElu;
  // The network anchored at the origin: y(x) - y(0) instead of y(x), so that the zero
  // input gives exactly zero (an auto-decoder's zero latent then decodes to its rest:
  // the neutral surface, the identity actuation). The output bias then cancels (its
  // gradient is zero). Forward and Backward evaluate the zero input as one extra
  // column of the batch.
  bool zero_at_origin = false;
  // A linear skip from the input to the output: y = network(x) + W_s x, with W_s
  // (output_dim x input_dim, column-major) stored after the last layer's bias. The
  // network then only needs to learn what is not linear in the input.
  bool linear_skip = false;
};

// What Forward() keeps for Backward(): per layer l (0-based, num_layers() of them),
// the layer's input h_l (width x batch; h_0 is a copy of the inputs) and, for hidden
// layers, the activation derivative sigma'(pre-activation) (same shape as the layer's
// output). The outputs themselves are not kept (the output layer is linear and needs
// nothing). Reused between calls without reallocation when shapes repeat.
struct MlpWorkspace {
  std::vector<Eigen::MatrixXd> layer_inputs;            // num_layers entries
  std::vector<Eigen::MatrixXd> activation_derivatives;  // num_layers - 1 entries
  // 1 when the last column is the zero input of an anchored network (not a sample).
  int extra_columns = 0;
  int batch_size() const {
    return layer_inputs.empty() ? 0 : static_cast<int>(layer_inputs[0].cols()) - extra_columns;
  }
};

// A multilayer perceptron y = W_L sigma(... sigma(W_1 x + b_1) ...) + b_L, evaluated in
// double precision on batches (one sample per column) with exact reverse-mode
// (backpropagation) and forward-mode (input Jacobian) derivatives.
//
// Parameters live in one flat array of num_parameters() doubles, owned by the caller
// (so that Ceres can optimise it directly). Layout, for layer l = 0 .. num_layers()-1
// with fan_in = n_l and fan_out = n_{l+1} (n_0 = input_dim, n_L = output_dim):
//
//   W_l: fan_out x fan_in, column-major (W_l(i, j) at offset_l + i + j fan_out),
//   b_l: fan_out numbers, right after W_l,
//
// layers in order, no padding: offset_0 = 0, offset_{l+1} = offset_l + fan_out (fan_in + 1);
// then, with MlpSpec::linear_skip, W_s (output_dim x input_dim, column-major) at
// skip_offset() = offset_L.
// Parameters are used in place through Eigen::Map (never copied).
//
// Memory: the parameters themselves, plus per call a workspace of
// sum_l n_l x batch (layer inputs) + sum_hidden n x batch (derivatives) doubles, plus
// the caller's outputs. Nothing of size output_dim x input_dim is formed except by
// InputJacobian(). An output layer of 1.5e6 x 128 is 192e6 weights (1.5 GB per copy
// of the parameters), and a forward or backward pass is one matrix product with it.
//
// Immutable after construction; the const methods are thread-safe as long as each
// thread uses its own workspace (and its own gradient array in Backward()).
class Mlp {
 public:
  // CHECKs that every dimension is positive and that num_parameters() fits an int.
  explicit Mlp(const MlpSpec& spec);

  const MlpSpec& spec() const { return spec_; }
  int input_dim() const { return spec_.input_dim; }
  int output_dim() const { return spec_.output_dim; }
  // Number of affine layers: hidden_dims.size() + 1.
  int num_layers() const { return static_cast<int>(widths_.size()) - 1; }
  int num_parameters() const { return static_cast<int>(num_parameters_); }
  // Offset of the skip weights W_s (only meaningful with MlpSpec::linear_skip).
  Eigen::Index skip_offset() const { return offsets_.back(); }
  // n_0 .. n_L: input_dim, hidden_dims..., output_dim.
  const std::vector<int>& widths() const { return widths_; }
  // Offset of W_l in the flat array (b_l follows at weight_offset(l) + n_{l+1} n_l).
  Eigen::Index weight_offset(int layer) const { return offsets_[layer]; }
  Eigen::Index bias_offset(int layer) const {
    return offsets_[layer] + static_cast<Eigen::Index>(widths_[layer + 1]) * widths_[layer];
  }

  // Fills params (num_parameters()) with random weights and zero biases. Hidden layers:
  // normal with standard deviation sqrt(2 / fan_in) (He) for kElu and kSoftplus,
  // sqrt(2 / (fan_in + fan_out)) (Glorot) for kTanh. The output layer: sqrt(1 / fan_in)
  // times output_layer_gain, so that initial outputs are O(output_layer_gain) for O(1)
  // inputs. Skip weights start at zero. Deterministic for a given seed (std::mt19937,
  // std::normal_distribution).
  void InitializeParameters(unsigned seed, double* params,
                            double output_layer_gain = 0.1) const;

  // Batched forward pass: inputs (input_dim x batch, one sample per column) ->
  // *outputs (resized to output_dim x batch). Keeps in *workspace what Backward()
  // needs (workspace may be reused; it is resized as needed).
  void Forward(const double* params, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
               Eigen::MatrixXd* outputs, MlpWorkspace* workspace) const;

  // Reverse mode for the batch of the last Forward() with `workspace`: given
  // output_gradient = dL/doutputs (output_dim x batch), ADDS dL/dparams to
  // param_gradient (num_parameters(), same layout as params; the caller zeroes it) and,
  // if input_gradient is not null, sets it to dL/dinputs (input_dim x batch).
  // Temporaries: two hidden-width x batch matrices.
  void Backward(const double* params, const MlpWorkspace& workspace,
                const Eigen::Ref<const Eigen::MatrixXd>& output_gradient,
                double* param_gradient, Eigen::MatrixXd* input_gradient) const;

  // Forward mode for one sample: the Jacobian d outputs / d input at `input`
  // (input_dim), set in *jacobian as output_dim x input_dim (column j = d outputs /
  // d input_j), propagated as input_dim directions through the layers (cost about
  // input_dim forward passes). If output is not null it receives the outputs
  // (output_dim). Memory: output_dim x input_dim doubles.
  void InputJacobian(const double* params, const Eigen::Ref<const Eigen::VectorXd>& input,
                     Eigen::MatrixXd* jacobian, Eigen::VectorXd* output = nullptr) const;

 private:
  // y(input) of the plain network (no anchoring), for one input.
  Eigen::VectorXd UnanchoredOutput(const double* params, const Eigen::VectorXd& input) const;

  MlpSpec spec_;
  std::vector<int> widths_;
  std::vector<Eigen::Index> offsets_;  // num_layers + 1 entries; back() = the layers' total
  Eigen::Index num_parameters_ = 0;   // the layers' total plus the skip weights
};

}  // namespace aqs

#endif  // AQS_LEARN_MLP_H_
