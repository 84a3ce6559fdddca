#include "learn/mlp.h"

#include <cmath>
#include <limits>
#include <random>

#include <glog/logging.h>

namespace aqs {
namespace {

using ConstMatrixMap = Eigen::Map<const Eigen::MatrixXd>;
using ConstVectorMap = Eigen::Map<const Eigen::VectorXd>;
using MatrixMap = Eigen::Map<Eigen::MatrixXd>;
using VectorMap = Eigen::Map<Eigen::VectorXd>;

// Replaces every entry x of *values by sigma(x) and sets *derivatives (same shape) to
// sigma'(x).
void ApplyActivation(Activation activation, Eigen::MatrixXd* values,
                     Eigen::MatrixXd* derivatives) {
  derivatives->resize(values->rows(), values->cols());
  double* x = values->data();
  double* d = derivatives->data();
  const Eigen::Index n = values->size();
  switch (activation) {
    case Activation::kElu:
      for (Eigen::Index i = 0; i < n; ++i) {
        if (x[i] > 0.0) {
          d[i] = 1.0;
        } else {
          d[i] = std::exp(x[i]);
          x[i] = std::expm1(x[i]);
        }
      }
      break;
    case Activation::kTanh:
      for (Eigen::Index i = 0; i < n; ++i) {
        x[i] = std::tanh(x[i]);
        d[i] = 1.0 - x[i] * x[i];
      }
      break;
    case Activation::kSoftplus:
      for (Eigen::Index i = 0; i < n; ++i) {
        const double e = std::exp(-std::abs(x[i]));  // in (0, 1]: no overflow
        d[i] = x[i] >= 0.0 ? 1.0 / (1.0 + e) : e / (1.0 + e);
        x[i] = std::max(x[i], 0.0) + std::log1p(e);
      }
      break;
  }
}

}  // namespace

std::string ActivationName(Activation activation) {
  switch (activation) {
    case Activation::kElu:
      return "elu";
    case Activation::kTanh:
      return "tanh";
    case Activation::kSoftplus:
      return "softplus";
  }
  return "unknown";
}

bool ActivationFromName(const std::string& name, Activation* activation) {
  for (Activation candidate : {Activation::kElu, Activation::kTanh, Activation::kSoftplus}) {
    if (name == ActivationName(candidate)) {
      *activation = candidate;
      return true;
    }
  }
  return false;
}

Mlp::Mlp(const MlpSpec& spec) : spec_(spec) {
  CHECK_GT(spec.input_dim, 0);
  CHECK_GT(spec.output_dim, 0);
  widths_.push_back(spec.input_dim);
  for (int width : spec.hidden_dims) {
    CHECK_GT(width, 0) << "hidden layer widths must be positive";
    widths_.push_back(width);
  }
  widths_.push_back(spec.output_dim);
  offsets_.push_back(0);
  for (size_t l = 0; l + 1 < widths_.size(); ++l) {
    offsets_.push_back(offsets_.back() + static_cast<Eigen::Index>(widths_[l + 1]) *
                                             (static_cast<Eigen::Index>(widths_[l]) + 1));
  }
  num_parameters_ = offsets_.back();
  if (spec.linear_skip) {
    num_parameters_ +=
        static_cast<Eigen::Index>(spec.output_dim) * static_cast<Eigen::Index>(spec.input_dim);
  }
  CHECK_LE(num_parameters_, std::numeric_limits<int>::max())
      << "too many parameters for one flat array indexed by int";
}

void Mlp::InitializeParameters(unsigned seed, double* params, double output_layer_gain) const {
  std::mt19937 rng(seed);
  for (int l = 0; l < num_layers(); ++l) {
    const int fan_in = widths_[l];
    const int fan_out = widths_[l + 1];
    double stddev;
    if (l + 1 == num_layers()) {
      stddev = output_layer_gain * std::sqrt(1.0 / fan_in);
    } else if (spec_.activation == Activation::kTanh) {
      stddev = std::sqrt(2.0 / (fan_in + fan_out));
    } else {
      stddev = std::sqrt(2.0 / fan_in);
    }
    std::normal_distribution<double> normal(0.0, stddev);
    double* weights = params + weight_offset(l);
    const Eigen::Index num_weights = static_cast<Eigen::Index>(fan_in) * fan_out;
    for (Eigen::Index i = 0; i < num_weights; ++i) weights[i] = normal(rng);
    VectorMap(params + bias_offset(l), fan_out).setZero();
  }
  if (spec_.linear_skip) {
    VectorMap(params + skip_offset(), num_parameters_ - skip_offset()).setZero();
  }
}

void Mlp::Forward(const double* params, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                  Eigen::MatrixXd* outputs, MlpWorkspace* workspace) const {
  CHECK_EQ(inputs.rows(), input_dim());
  const int num_hidden = num_layers() - 1;
  workspace->layer_inputs.resize(num_layers());
  workspace->activation_derivatives.resize(num_hidden);
  workspace->extra_columns = spec_.zero_at_origin ? 1 : 0;
  if (spec_.zero_at_origin) {  // the zero input as the last column
    workspace->layer_inputs[0].resize(inputs.rows(), inputs.cols() + 1);
    workspace->layer_inputs[0].leftCols(inputs.cols()) = inputs;
    workspace->layer_inputs[0].rightCols(1).setZero();
  } else {
    workspace->layer_inputs[0] = inputs;
  }
  for (int l = 0; l < num_hidden; ++l) {
    const ConstMatrixMap w(params + weight_offset(l), widths_[l + 1], widths_[l]);
    const ConstVectorMap b(params + bias_offset(l), widths_[l + 1]);
    Eigen::MatrixXd& z = workspace->layer_inputs[l + 1];
    z.noalias() = w * workspace->layer_inputs[l];
    z.colwise() += b;
    ApplyActivation(spec_.activation, &z, &workspace->activation_derivatives[l]);
  }
  const int last = num_layers() - 1;
  const ConstMatrixMap w(params + weight_offset(last), widths_[last + 1], widths_[last]);
  const ConstVectorMap b(params + bias_offset(last), widths_[last + 1]);
  outputs->noalias() = w * workspace->layer_inputs[last];
  outputs->colwise() += b;
  if (spec_.linear_skip) {
    const ConstMatrixMap skip(params + skip_offset(), output_dim(), input_dim());
    outputs->noalias() += skip * workspace->layer_inputs[0];
  }
  if (spec_.zero_at_origin) {
    const Eigen::VectorXd origin = outputs->rightCols(1);
    const Eigen::Index samples = outputs->cols() - 1;
    outputs->conservativeResize(Eigen::NoChange, samples);
    outputs->colwise() -= origin;
  }
}

void Mlp::Backward(const double* params, const MlpWorkspace& workspace,
                   const Eigen::Ref<const Eigen::MatrixXd>& output_gradient,
                   double* param_gradient, Eigen::MatrixXd* input_gradient) const {
  CHECK_EQ(static_cast<int>(workspace.layer_inputs.size()), num_layers())
      << "call Forward() with this workspace first";
  CHECK_EQ(output_gradient.rows(), output_dim());
  CHECK_EQ(output_gradient.cols(), workspace.batch_size());
  // An anchored network's outputs are y(x_p) - y(0): the zero column gets minus the sum
  // of the samples' output gradients.
  Eigen::MatrixXd extended;
  if (workspace.extra_columns > 0) {
    extended.resize(output_gradient.rows(), output_gradient.cols() + 1);
    extended.leftCols(output_gradient.cols()) = output_gradient;
    extended.rightCols(1) = -output_gradient.rowwise().sum();
  }
  const Eigen::Ref<const Eigen::MatrixXd> top =
      workspace.extra_columns > 0 ? Eigen::Ref<const Eigen::MatrixXd>(extended)
                                  : output_gradient;
  if (spec_.linear_skip) {  // the zero column's input is zero: no weight gradient from it
    MatrixMap dskip(param_gradient + skip_offset(), output_dim(), input_dim());
    dskip.noalias() += top * workspace.layer_inputs[0].transpose();
  }
  // gradient: dL/d(output of layer l), starting with the given one at the top.
  Eigen::MatrixXd gradient;
  Eigen::MatrixXd below;
  for (int l = num_layers() - 1; l >= 0; --l) {
    const Eigen::Ref<const Eigen::MatrixXd> g =
        (l == num_layers() - 1) ? top : Eigen::Ref<const Eigen::MatrixXd>(gradient);
    const Eigen::MatrixXd& h = workspace.layer_inputs[l];
    MatrixMap dw(param_gradient + weight_offset(l), widths_[l + 1], widths_[l]);
    VectorMap db(param_gradient + bias_offset(l), widths_[l + 1]);
    dw.noalias() += g * h.transpose();
    db += g.rowwise().sum();
    if (l == 0 && input_gradient == nullptr) break;
    const ConstMatrixMap w(params + weight_offset(l), widths_[l + 1], widths_[l]);
    below.noalias() = w.transpose() * g;
    if (l > 0) {
      below.array() *= workspace.activation_derivatives[l - 1].array();
      gradient.swap(below);
    } else {
      *input_gradient = below.leftCols(below.cols() - workspace.extra_columns);
    }
  }
  if (input_gradient != nullptr && spec_.linear_skip) {
    const ConstMatrixMap skip(params + skip_offset(), output_dim(), input_dim());
    input_gradient->noalias() += skip.transpose() * output_gradient;
  }
}

void Mlp::InputJacobian(const double* params, const Eigen::Ref<const Eigen::VectorXd>& input,
                        Eigen::MatrixXd* jacobian, Eigen::VectorXd* output) const {
  CHECK_EQ(input.size(), input_dim());
  // h: the layer input; t = dh/dinput (width x input_dim).
  Eigen::MatrixXd h = input;
  Eigen::MatrixXd t = Eigen::MatrixXd::Identity(input_dim(), input_dim());
  Eigen::MatrixXd derivative;
  Eigen::MatrixXd next;
  for (int l = 0; l + 1 < num_layers(); ++l) {
    const ConstMatrixMap w(params + weight_offset(l), widths_[l + 1], widths_[l]);
    const ConstVectorMap b(params + bias_offset(l), widths_[l + 1]);
    next.noalias() = w * h;
    next.colwise() += b;
    ApplyActivation(spec_.activation, &next, &derivative);
    h.swap(next);
    next.noalias() = w * t;
    next.array().colwise() *= derivative.col(0).array();
    t.swap(next);
  }
  const int last = num_layers() - 1;
  const ConstMatrixMap w(params + weight_offset(last), widths_[last + 1], widths_[last]);
  jacobian->noalias() = w * t;
  if (output != nullptr) {
    const ConstVectorMap b(params + bias_offset(last), widths_[last + 1]);
    output->noalias() = w * h.col(0);
    *output += b;
    if (spec_.zero_at_origin) *output -= UnanchoredOutput(params, Eigen::VectorXd::Zero(input_dim()));
  }
  if (spec_.linear_skip) {
    const ConstMatrixMap skip(params + skip_offset(), output_dim(), input_dim());
    *jacobian += skip;
    if (output != nullptr) output->noalias() += skip * input;
  }
}

Eigen::VectorXd Mlp::UnanchoredOutput(const double* params, const Eigen::VectorXd& input) const {
  Eigen::MatrixXd h = input;
  Eigen::MatrixXd derivative;
  for (int l = 0; l + 1 < num_layers(); ++l) {
    const ConstMatrixMap w(params + weight_offset(l), widths_[l + 1], widths_[l]);
    const ConstVectorMap b(params + bias_offset(l), widths_[l + 1]);
    Eigen::MatrixXd next = w * h;
    next.colwise() += b;
    ApplyActivation(spec_.activation, &next, &derivative);
    h.swap(next);
  }
  const int last = num_layers() - 1;
  const ConstMatrixMap w(params + weight_offset(last), widths_[last + 1], widths_[last]);
  const ConstVectorMap b(params + bias_offset(last), widths_[last + 1]);
  Eigen::VectorXd y = w * h.col(0) + b;
  if (spec_.linear_skip) {
    y.noalias() += ConstMatrixMap(params + skip_offset(), output_dim(), input_dim()) * input;
  }
  return y;
}

}  // namespace aqs
