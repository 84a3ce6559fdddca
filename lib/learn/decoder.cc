#include "learn/decoder.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <utility>

#include <glog/logging.h>

#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

// What a reader allocates before it has read that many entries of a counted list.
constexpr int kReadChunk = 1 << 16;

constexpr char kMagic[] = "aqs_actuation_decoder";
constexpr int kVersion = 1;

using ConstNodeValueMap = Eigen::Map<const NodeValueMatrix>;

}  // namespace

bool DecoderSpec::Validate(std::string* error) const {
  OptionChecks checks;
  checks.IntInRange("latent_dim", latent_dim, 1, kMaxLatentDim)
      .InRange("output_scale", output_scale, kMinDecoderOutputScale, kMaxDecoderOutputScale);
  for (int width : hidden_dims) {
    checks.Require(width >= 1, "hidden_dims must be positive widths (has " +
                                   std::to_string(width) + ")");
  }
  return checks.Done(error);
}

MlpSpec DecoderMlpSpec(const DecoderSpec& spec, int num_nodes) {
  CHECK_GT(spec.latent_dim, 0);
  CHECK_GT(num_nodes, 0);
  CHECK(spec.output_scale > 0.0 && std::isfinite(spec.output_scale))
      << "output_scale " << spec.output_scale;
  CHECK_LE(num_nodes, std::numeric_limits<int>::max() / 6);
  MlpSpec mlp;
  mlp.input_dim = spec.latent_dim;
  mlp.hidden_dims = spec.hidden_dims;
  mlp.output_dim = 6 * num_nodes;
  mlp.activation = spec.activation;
  mlp.zero_at_origin = spec.anchored;
  mlp.linear_skip = spec.linear_skip;
  return mlp;
}

ActuationDecoder::ActuationDecoder(const DecoderSpec& spec, GridActuationField field)
    : spec_(spec), field_(std::move(field)), mlp_(DecoderMlpSpec(spec, field_.num_nodes())) {}

void ActuationDecoder::InitializeParameters(unsigned seed, double* params,
                                            double output_layer_gain) const {
  mlp_.InitializeParameters(seed, params, output_layer_gain);
}

void ActuationDecoder::Decode(const double* params, const Eigen::Ref<const Eigen::VectorXd>& z,
                              ActuationMatrix* a, DecoderWorkspace* workspace) const {
  CHECK_EQ(z.size(), latent_dim());
  mlp_.Forward(params, z, &workspace->node_values, &workspace->mlp);
  workspace->node_values *= spec_.output_scale;
  field_.Apply(ConstNodeValueMap(workspace->node_values.data(), 6, num_nodes()), a);
}

void ActuationDecoder::DecodeBatch(const double* params,
                                   const Eigen::Ref<const Eigen::MatrixXd>& latents,
                                   std::vector<ActuationMatrix>* a,
                                   DecoderWorkspace* workspace) const {
  CHECK_EQ(latents.rows(), latent_dim());
  mlp_.Forward(params, latents, &workspace->node_values, &workspace->mlp);
  workspace->node_values *= spec_.output_scale;
  a->resize(latents.cols());
  for (Eigen::Index p = 0; p < latents.cols(); ++p) {
    field_.Apply(ConstNodeValueMap(workspace->node_values.col(p).data(), 6, num_nodes()),
                 &(*a)[p]);
  }
}

void ActuationDecoder::Backward(const double* params, const DecoderWorkspace& workspace,
                                const std::vector<ActuationMatrix>& dl_da,
                                double* param_gradient,
                                Eigen::MatrixXd* latent_gradient) const {
  CHECK_EQ(static_cast<int>(dl_da.size()), workspace.batch_size())
      << "one dL/da per decoded pose";
  // dL/d(mlp outputs) = output_scale * field^T dL/da, one column per pose.
  Eigen::MatrixXd output_gradient(mlp_.output_dim(), dl_da.size());
  NodeValueMatrix node_gradient;
  for (size_t p = 0; p < dl_da.size(); ++p) {
    field_.ApplyTranspose(dl_da[p], &node_gradient);
    output_gradient.col(p) =
        spec_.output_scale * Eigen::Map<const Eigen::VectorXd>(node_gradient.data(),
                                                               node_gradient.size());
  }
  mlp_.Backward(params, workspace.mlp, output_gradient, param_gradient, latent_gradient);
}

void ActuationDecoder::Backward(const double* params, const DecoderWorkspace& workspace,
                                const ActuationMatrix& dl_da, double* param_gradient,
                                Eigen::MatrixXd* latent_gradient) const {
  CHECK_EQ(workspace.batch_size(), 1) << "use the batched Backward() after DecodeBatch()";
  CHECK_EQ(dl_da.cols(), num_elements());
  NodeValueMatrix node_gradient;
  field_.ApplyTranspose(dl_da, &node_gradient);
  node_gradient *= spec_.output_scale;
  mlp_.Backward(params, workspace.mlp,
                Eigen::Map<const Eigen::MatrixXd>(node_gradient.data(), node_gradient.size(), 1),
                param_gradient, latent_gradient);
}

Eigen::MatrixXd ActuationDecoder::ActuationJacobian(const double* params,
                                                    const Eigen::Ref<const Eigen::VectorXd>& z,
                                                    ActuationMatrix* a) const {
  CHECK_EQ(z.size(), latent_dim());
  Eigen::MatrixXd mlp_jacobian;
  Eigen::VectorXd outputs;
  mlp_.InputJacobian(params, z, &mlp_jacobian, a != nullptr ? &outputs : nullptr);
  mlp_jacobian *= spec_.output_scale;
  if (a != nullptr) {
    outputs *= spec_.output_scale;
    field_.Apply(ConstNodeValueMap(outputs.data(), 6, num_nodes()), a);
  }
  if (field_.per_element()) return mlp_jacobian;  // the field is the identity
  Eigen::MatrixXd jacobian(6 * static_cast<Eigen::Index>(num_elements()), latent_dim());
  ActuationMatrix column;
  for (int j = 0; j < latent_dim(); ++j) {
    field_.Interpolate(ConstNodeValueMap(mlp_jacobian.col(j).data(), 6, num_nodes()), &column);
    jacobian.col(j) = Eigen::Map<const Eigen::VectorXd>(column.data(), column.size());
  }
  return jacobian;
}

DecoderMemory DecoderMemoryBytes(const DecoderSpec& spec, const GridFieldDescription& field,
                                 int batch_size) {
  return DecoderMemoryBytes(spec, field.num_elements, field.num_nodes(), field.per_element,
                            batch_size);
}

DecoderMemory DecoderMemoryBytes(const DecoderSpec& spec, double num_elements, double num_nodes,
                                 bool per_element, double batch_size, double* num_parameters) {
  constexpr double kDouble = sizeof(double);
  const double outputs = 6.0 * num_nodes;
  const double d = spec.latent_dim;
  const double batch = batch_size;
  double parameters = 0.0;
  double hidden_sum = 0.0;
  double widest_hidden = 0.0;
  double fan_in = d;
  for (int width : spec.hidden_dims) {
    parameters += width * (fan_in + 1.0);
    hidden_sum += width;
    widest_hidden = std::max<double>(widest_hidden, width);
    fan_in = width;
  }
  parameters += outputs * (fan_in + 1.0);
  if (spec.linear_skip) parameters += outputs * d;
  if (num_parameters != nullptr) *num_parameters = parameters;

  DecoderMemory memory;
  memory.parameters = kDouble * parameters;
  memory.field = per_element ? 0.0 : num_elements * 8.0 * (sizeof(int32_t) + kDouble);
  // Workspace: layer inputs (d + hidden widths) and derivatives (hidden) per pose, node
  // values per pose; Backward: the output gradient, a node gradient, two hidden blocks.
  memory.workspace = kDouble * (batch * (d + 2.0 * hidden_sum + outputs) +
                                batch * outputs + outputs + 2.0 * batch * widest_hidden);
  memory.actuations = kDouble * 2.0 * batch * 6.0 * num_elements;
  // The result, the MLP-level Jacobian and the forward-mode directions, one column of a.
  const double grid_scratch = per_element ? 0.0 : outputs * d + 6.0 * num_elements;
  memory.actuation_jacobian =
      kDouble * (6.0 * num_elements * d + grid_scratch + 2.0 * widest_hidden * d);
  memory.total = memory.parameters + memory.field + memory.workspace + memory.actuations +
                 memory.actuation_jacobian;
  return memory;
}

bool SaveDecoder(const std::string& path, const DecoderSpec& spec,
                 const GridFieldDescription& field,
                 const Eigen::Ref<const Eigen::VectorXd>& params, std::string* error) {
  const Mlp mlp(DecoderMlpSpec(spec, field.num_nodes()));
  CHECK_EQ(params.size(), mlp.num_parameters()) << "parameters do not match spec and field";
  AtomicFileWriter writer(path);
  std::string text;
  text.reserve(1 << 20);
  auto flush = [&writer, &text]() {
    writer.stream() << text;
    text.clear();
  };
  text += "# ActiveQS actuation decoder, a = I + field(output_scale * mlp(z)); format: "
          "lib/learn/decoder.h\n";
  text += std::string(kMagic) + " " + std::to_string(kVersion) + "\n";
  text += "latent_dim " + std::to_string(spec.latent_dim) + "\n";
  text += "hidden_dims " + std::to_string(spec.hidden_dims.size());
  for (int width : spec.hidden_dims) text += " " + std::to_string(width);
  text += "\nactivation " + ActivationName(spec.activation) + "\noutput_scale ";
  AppendDouble(spec.output_scale, &text);
  text += spec.anchored ? "\nanchored 1" : "\nanchored 0";
  if (spec.linear_skip) text += "\nlinear_skip 1";
  text += "\nfield ";
  text += field.per_element ? "per_element" : "grid";
  text += "\nnum_elements " + std::to_string(field.num_elements) + "\n";
  if (!field.per_element) {
    text += "origin";
    for (int a = 0; a < 3; ++a) {
      text += ' ';
      AppendDouble(field.origin[a], &text);
    }
    text += "\nspacing ";
    AppendDouble(field.spacing, &text);
    text += "\ngrid_dims " + std::to_string(field.grid_dims[0]) + " " +
            std::to_string(field.grid_dims[1]) + " " + std::to_string(field.grid_dims[2]);
    text += "\nnum_nodes " + std::to_string(field.nodes.cols()) + "\n";
    text += "# grid coordinates i j k of each control node\n";
    for (Eigen::Index n = 0; n < field.nodes.cols(); ++n) {
      text += std::to_string(field.nodes(0, n)) + " " + std::to_string(field.nodes(1, n)) +
              " " + std::to_string(field.nodes(2, n)) + "\n";
    }
  }
  text += "num_parameters " + std::to_string(params.size()) + "\n";
  for (int l = 0; l < mlp.num_layers(); ++l) {
    const int fan_out = mlp.widths()[l + 1];
    const int fan_in = mlp.widths()[l];
    text += "# layer " + std::to_string(l) + ": W " + std::to_string(fan_out) + " x " +
            std::to_string(fan_in) + " column-major\n";
    for (Eigen::Index i = mlp.weight_offset(l); i < mlp.bias_offset(l); ++i) {
      AppendDouble(params[i], &text);
      text += '\n';
      if (text.size() > (1 << 20)) flush();
    }
    text += "# layer " + std::to_string(l) + ": b " + std::to_string(fan_out) + "\n";
    for (Eigen::Index i = mlp.bias_offset(l); i < mlp.bias_offset(l) + fan_out; ++i) {
      AppendDouble(params[i], &text);
      text += '\n';
    }
  }
  if (spec.linear_skip) {
    text += "# linear skip: W_s " + std::to_string(mlp.output_dim()) + " x " +
            std::to_string(mlp.input_dim()) + " column-major\n";
    for (Eigen::Index i = mlp.skip_offset(); i < mlp.num_parameters(); ++i) {
      AppendDouble(params[i], &text);
      text += '\n';
      if (text.size() > (1 << 20)) flush();
    }
  }
  flush();
  return writer.Commit(error);
}

namespace {

// Reads decoder files: the next non-comment line, checked against what it must hold.
class DecoderReader {
 public:
  explicit DecoderReader(const std::string& path) : reader_(path) {}

  bool ok() const { return reader_.ok(); }
  const std::string& open_error() const { return reader_.error(); }
  const std::string& error() const { return error_; }

  // The next line must be `key` followed by `count` tokens (count < 0: any number, at
  // least one), left in *values.
  bool Keyword(const std::string& key, int count, std::vector<std::string>* values) {
    std::vector<std::string> tokens;
    if (!reader_.NextTokens(&tokens)) return EndOfFile("'" + key + "'");
    if (tokens[0] != key) return Fail("expected '" + key + "', got '" + tokens[0] + "'");
    values->assign(tokens.begin() + 1, tokens.end());
    if ((count >= 0 && static_cast<int>(values->size()) != count) ||
        (count < 0 && values->empty())) {
      std::ostringstream out;
      out << "'" << key << "' takes " << (count < 0 ? std::string("one or more")
                                                     : std::to_string(count))
          << " value(s), got " << values->size();
      return Fail(out.str());
    }
    return true;
  }

  // The next line's tokens, whatever they are (`expected` names it on end of file).
  bool Line(const std::string& expected, std::vector<std::string>* tokens) {
    if (!reader_.NextTokens(tokens)) return EndOfFile(expected);
    return true;
  }

  // The next line: exactly `count` tokens, for `what` number `index` (messages only).
  bool Values(int count, const char* what, int64_t index, std::vector<std::string>* tokens) {
    if (!reader_.NextTokens(tokens)) return EndOfFile(Name(what, index));
    if (static_cast<int>(tokens->size()) != count) {
      std::ostringstream out;
      out << "expected " << count << " number(s) (" << Name(what, index) << "), got "
          << tokens->size();
      return Fail(out.str());
    }
    return true;
  }

  // A positive int, naming `what` on failure.
  bool PositiveInt(const std::string& token, const std::string& what, int* value) {
    if (!ParseInt(token, value) || *value <= 0) {
      return Fail(what + " must be a positive integer, got '" + token + "'");
    }
    return true;
  }

  bool Double(const std::string& token, const char* what, double* value, int64_t index = -1) {
    if (!ParseDouble(token, value)) {
      return Fail("expected a finite number (" + Name(what, index) + "), got '" + token + "'");
    }
    return true;
  }

  // Nothing but comments may follow.
  bool AtEnd() {
    std::vector<std::string> tokens;
    if (reader_.NextTokens(&tokens)) return Fail("unexpected content after the parameters");
    if (!reader_.ok()) {
      error_ = reader_.error();
      return false;
    }
    return true;
  }

  bool Fail(const std::string& message) {
    error_ = reader_.Where(message);
    return false;
  }

 private:
  static std::string Name(const char* what, int64_t index) {
    return index < 0 ? std::string(what) : std::string(what) + " " + std::to_string(index);
  }

  bool EndOfFile(const std::string& expected) {
    if (!reader_.ok()) {
      error_ = reader_.error();
      return false;
    }
    return Fail("unexpected end of file, expected " + expected);
  }

  LineReader reader_;
  std::string error_;
};

// The decoder's sizes (the lines from the magic to output_scale, and the optional
// "anchored" and "linear_skip" lines) into *spec. False with the reader's error.
bool ReadDecoderSpec(DecoderReader* in, DecoderSpec* spec) {
  std::vector<std::string> v;
  if (!in->Keyword(kMagic, 1, &v)) return false;
  int version = 0;
  if (!ParseInt(v[0], &version) || version != kVersion) {
    return in->Fail("unsupported decoder file version '" + v[0] + "' (this build reads " +
                    std::to_string(kVersion) + ")");
  }
  DecoderSpec& s = *spec;
  if (!in->Keyword("latent_dim", 1, &v) || !in->PositiveInt(v[0], "latent_dim", &s.latent_dim)) {
    return false;
  }
  if (!in->Keyword("hidden_dims", -1, &v)) return false;
  int num_hidden = 0;
  if (!ParseInt(v[0], &num_hidden) || num_hidden < 0) {
    return in->Fail("the number of hidden layers must be a non-negative integer, got '" + v[0] +
                    "'");
  }
  if (static_cast<int>(v.size()) != num_hidden + 1) {
    return in->Fail("'hidden_dims " + v[0] + "' must be followed by " + v[0] + " widths, got " +
                    std::to_string(v.size() - 1));
  }
  s.hidden_dims.resize(num_hidden);
  for (int l = 0; l < num_hidden; ++l) {
    if (!in->PositiveInt(v[l + 1], "a hidden width", &s.hidden_dims[l])) return false;
  }
  if (!in->Keyword("activation", 1, &v)) return false;
  if (!ActivationFromName(v[0], &s.activation)) {
    return in->Fail("unknown activation '" + v[0] + "' (elu, tanh or softplus)");
  }
  if (!in->Keyword("output_scale", 1, &v) ||
      !in->Double(v[0], "output_scale", &s.output_scale)) {
    return false;
  }
  if (!(s.output_scale > 0.0)) {
    return in->Fail("output_scale must be positive, got '" + v[0] + "'");
  }
  return true;
}

// The optional lines after the sizes (files before them have none), in this order:
// "anchored 0|1", "linear_skip 0|1", into *spec; then the "field <kind>" line's tokens
// (*field_line). False with the reader's error.
bool ReadDecoderFlags(DecoderReader* in, DecoderSpec* spec, std::vector<std::string>* field_line) {
  std::vector<std::string>& tokens = *field_line;
  if (!in->Line("'field'", &tokens)) return false;
  for (const auto& [key, value] :
       {std::pair<std::string, bool*>{"anchored", &spec->anchored},
        std::pair<std::string, bool*>{"linear_skip", &spec->linear_skip}}) {
    if (tokens[0] != key) continue;
    if (tokens.size() != 2 || (tokens[1] != "0" && tokens[1] != "1")) {
      return in->Fail("'" + key + "' takes 0 or 1");
    }
    *value = tokens[1] == "1";
    if (!in->Line("'field'", &tokens)) return false;
  }
  return true;
}

// A grid field's lines after num_elements (origin, spacing, grid_dims, num_nodes, the
// nodes' grid coordinates in increasing grid index) into *f. False with the reader's
// error.
bool ReadGridField(DecoderReader* in, GridFieldDescription* f) {
  std::vector<std::string> v;
  if (!in->Keyword("origin", 3, &v)) return false;
  for (int a = 0; a < 3; ++a) {
    if (!in->Double(v[a], "origin", &f->origin[a])) return false;
  }
  if (!in->Keyword("spacing", 1, &v) || !in->Double(v[0], "spacing", &f->spacing)) {
    return false;
  }
  if (!(f->spacing > 0.0)) return in->Fail("spacing must be positive, got '" + v[0] + "'");
  if (!in->Keyword("grid_dims", 3, &v)) return false;
  for (int a = 0; a < 3; ++a) {
    if (!in->PositiveInt(v[a], "grid_dims", &f->grid_dims[a])) return false;
    if (f->grid_dims[a] < 2) {
      return in->Fail("grid_dims must be at least 2 along each axis, got " + v[a]);
    }
  }
  if (f->grid_dims.cast<double>().prod() > kMaxGridNodes) {
    return in->Fail("grid_dims describe an implausibly large grid");
  }
  int num_nodes = 0;
  if (!in->Keyword("num_nodes", 1, &v) || !in->PositiveInt(v[0], "num_nodes", &num_nodes)) {
    return false;
  }
  if (num_nodes > std::numeric_limits<int>::max() / 6 ||
      static_cast<double>(num_nodes) >
          static_cast<double>(f->grid_dims[0]) * f->grid_dims[1] * f->grid_dims[2]) {
    return in->Fail("num_nodes " + v[0] + " is more than the grid holds");
  }
  // Grown as the nodes are read, not sized by the count: a damaged count would allocate
  // gigabytes before the file's end is found.
  f->nodes.resize(3, std::min(num_nodes, kReadChunk));
  int64_t previous = -1;
  for (int n = 0; n < num_nodes; ++n) {
    if (!in->Values(3, "grid coordinates i j k of node", n, &v)) return false;
    if (n == f->nodes.cols()) {
      f->nodes.conservativeResize(3, std::min<int64_t>(num_nodes, 2 * static_cast<int64_t>(n)));
    }
    for (int a = 0; a < 3; ++a) {
      int value = 0;
      if (!ParseInt(v[a], &value) || value < 0 || value >= f->grid_dims[a]) {
        return in->Fail("grid coordinate '" + v[a] + "' of node " + std::to_string(n) +
                        " is not an integer in [0, " + std::to_string(f->grid_dims[a]) + ")");
      }
      f->nodes(a, n) = value;
    }
    const int64_t nx = f->grid_dims[0];
    const int64_t ny = f->grid_dims[1];
    const int64_t index = f->nodes(0, n) + nx * (f->nodes(1, n) + ny * f->nodes(2, n));
    if (index <= previous) {
      return in->Fail("node " + std::to_string(n) + " is out of order or repeated (nodes must "
                      "be in increasing grid index i + nx (j + ny k))");
    }
    previous = index;
  }
  return true;
}

// The field: its "field <kind>" line's tokens (`field_line`) and the lines after it,
// into *f. False with the reader's error.
bool ReadDecoderField(DecoderReader* in, const std::vector<std::string>& field_line,
                      GridFieldDescription* f) {
  if (field_line[0] != "field" || field_line.size() != 2) {
    return in->Fail("expected 'field grid' or 'field per_element'");
  }
  if (field_line[1] == "per_element") {
    f->per_element = true;
  } else if (field_line[1] != "grid") {
    return in->Fail("unknown field '" + field_line[1] + "' (grid or per_element)");
  }
  std::vector<std::string> v;
  if (!in->Keyword("num_elements", 1, &v) ||
      !in->PositiveInt(v[0], "num_elements", &f->num_elements)) {
    return false;
  }
  if (!f->per_element && !ReadGridField(in, f)) return false;
  if (f->num_nodes() > std::numeric_limits<int>::max() / 6) return in->Fail("too many nodes");
  return true;
}

// The parameter count the sizes imply, or -1 where it is above INT_MAX (Mlp CHECKs that
// it fits an int). Summed in double, which holds every count up to 2^53 exactly and
// cannot wrap as int64 did: layers of 2^31 - 1 units passed for 970 parameters.
int64_t DecoderParameterCount(const DecoderSpec& s, const GridFieldDescription& f) {
  const double limit = std::numeric_limits<int>::max();
  double count = 0;
  double fan_in = s.latent_dim;
  for (int width : s.hidden_dims) {
    count += static_cast<double>(width) * (fan_in + 1);
    fan_in = width;
  }
  count += 6.0 * f.num_nodes() * (fan_in + 1);
  if (s.linear_skip) count += 6.0 * f.num_nodes() * s.latent_dim;
  return count <= limit ? static_cast<int64_t>(count) : -1;
}

// The "num_parameters" line, which must say `expected`, and the parameters, one per
// line, into *p. False with the reader's error.
bool ReadDecoderParameters(DecoderReader* in, int64_t expected, Eigen::VectorXd* p) {
  std::vector<std::string> v;
  if (!in->Keyword("num_parameters", 1, &v)) return false;
  if (expected < 0) {
    return in->Fail("the layer sizes need more than " +
                    std::to_string(std::numeric_limits<int>::max()) + " parameters");
  }
  long long count = 0;
  if (!ParseInt64(v[0], &count) || count != expected) {
    return in->Fail("num_parameters '" + v[0] + "' does not match the layer sizes, which need " +
                    std::to_string(expected));
  }
  if (expected > std::numeric_limits<int>::max()) {
    return in->Fail("too many parameters (" + std::to_string(expected) + ")");
  }
  // Grown as the parameters are read (see the nodes).
  p->resize(std::min<int64_t>(expected, kReadChunk));
  for (int64_t i = 0; i < expected; ++i) {
    if (i == p->size()) p->conservativeResize(std::min(expected, 2 * i));
    if (!in->Values(1, "parameter", i, &v) || !in->Double(v[0], "parameter", &(*p)[i], i)) {
      return false;
    }
  }
  return true;
}

}  // namespace

bool LoadDecoder(const std::string& path, DecoderSpec* spec, GridFieldDescription* field,
                 Eigen::VectorXd* params, std::string* error) {
  DecoderReader in(path);
  if (!in.ok()) {
    *error = in.open_error();
    return false;
  }
  DecoderSpec s;
  GridFieldDescription f;
  Eigen::VectorXd p;
  std::vector<std::string> field_line;
  std::string invalid;
  if (!ReadDecoderSpec(&in, &s) || !ReadDecoderFlags(&in, &s, &field_line)) {
    *error = in.error();
    return false;
  }
  if (!s.Validate(&invalid)) {
    *error = path + ": " + invalid;
    return false;
  }
  if (!ReadDecoderField(&in, field_line, &f) ||
      !ReadDecoderParameters(&in, DecoderParameterCount(s, f), &p) || !in.AtEnd()) {
    *error = in.error();
    return false;
  }
  *spec = std::move(s);
  *field = std::move(f);
  *params = std::move(p);
  return true;
}

}  // namespace aqs
