#ifndef AQS_LEARN_DECODER_H_
#define AQS_LEARN_DECODER_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "learn/grid_actuation_field.h"
#include "learn/mlp.h"
#include "physics/actuation.h"

namespace aqs {

// The largest latent dimension DecoderSpec::Validate accepts (a latent describes a pose
// by a few numbers; the demo uses 8). Fits hold d x d prior covariances and Jacobians:
// 128 MB each at this size.
constexpr int kMaxLatentDim = 4096;
// The range DecoderSpec::Validate accepts for output_scale (a strain per unit output):
// at 1e-6 a strain of 0.1 needs raw outputs of 1e5, at 1e6 an output of 1e-7 is already
// 10% strain; outside, the network cannot be trained (1e-300 accepted before 2026-12-07
// left every actuation at I and every gradient at 0).
constexpr double kMinDecoderOutputScale = 1e-6;
constexpr double kMaxDecoderOutputScale = 1e6;

// Architecture of an ActuationDecoder (saved in decoder files together with the field
// description and the parameters).
struct DecoderSpec {
  // Dimension d of the latent vector z.
  int latent_dim = 16;
  std::vector<int> hidden_dims = {128, 128};
  Activation activation = Activation::kElu;
  // The MLP's outputs are multiplied by output_scale before the field: a = I +
  // field(output_scale * mlp(z)). Useful actuations deviate from I by about 0.05 to 0.3
  // (5 to 30% strain), so with 0.1 the raw outputs of a trained network are O(1), the
  // same scale as its hidden units, which keeps the output-layer weights and their
  // gradients on the scale of the others (better conditioned for L-BFGS). In
  // [kMinDecoderOutputScale, kMaxDecoderOutputScale].
  double output_scale = 0.1;
  // Anchored at the origin: a(z) = I + field(output_scale (mlp(z) - mlp(0))), so that
  // z = 0 decodes to the identity actuation exactly (the rest shape: the neutral, for a
  // face) and the latent prior pulls towards it (MlpSpec::zero_at_origin).
  bool anchored = false;
  // A linear part beside the network: a(z) = I + field(output_scale (mlp(z) + W_s z)),
  // W_s (6 num_nodes x latent_dim) learned with the rest (MlpSpec::linear_skip).
  bool linear_skip = false;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// What Decode()/DecodeBatch() keep for Backward(): the MLP's workspace and the node
// values output_scale * mlp(z) (6 num_nodes x batch; column p is pose p's
// NodeValueMatrix flattened column-major). One per thread.
struct DecoderWorkspace {
  MlpWorkspace mlp;
  Eigen::MatrixXd node_values;
  int batch_size() const { return static_cast<int>(node_values.cols()); }
};

// The Mlp of a decoder with `spec` and num_nodes control nodes: input_dim = latent_dim,
// output_dim = 6 num_nodes, spec's hidden widths and activation. CHECKs the spec.
MlpSpec DecoderMlpSpec(const DecoderSpec& spec, int num_nodes);

// Memory of the pieces of a decoder, in bytes (DecoderMemoryBytes).
struct DecoderMemory {
  double parameters = 0.0;          // one flat parameter array (a gradient is as large)
  double field = 0.0;               // the field's interpolation tables
  double workspace = 0.0;           // DecoderWorkspace and Backward() temporaries
  double actuations = 0.0;          // decoded actuations plus dL/da, for the whole batch
  double actuation_jacobian = 0.0;  // ActuationJacobian()'s result and intermediates
  double total = 0.0;               // the sum of the above
};

// The learned actuation space:
//
//   a(z) = I + field(output_scale * mlp(z; params)),     z in R^d,
//
// with mlp an Mlp of input_dim = d and output_dim = 6 num_nodes (output rows
// 6n .. 6n+5 = the six numbers of control node n) and field a GridActuationField
// (trilinear interpolation from a coarse grid of control nodes, or one node per
// element). The parameters are exactly the Mlp's (same flat layout; see learn/mlp.h):
// num_parameters() doubles owned by the caller.
//
// Memory at 250,000 elements (DecoderMemoryBytes, checked by decoder_test.cc, on the
// benchmark's 35^3-cube Kuhn lattice: 257,250 elements, cube edge c, MeanEdgeLength
// 1.26 c; default spec d = 16, hidden {128, 128}, ELU; GridActuationFieldOptions'
// default spacing 4 x MeanEdgeLength = 5.04 c):
//
//   grid (default): 8 x 8 x 8 = 512 control nodes, 3,072 MLP outputs, 414,976
//     parameters = 3.3 MB per parameter array (396,288 of them in the 3,072 x 129
//     output layer; Ceres' L-BFGS history, 2 x max_lbfgs_rank = 40 arrays, 133 MB);
//     field tables 24.7 MB; per decoded pose 12.3 MB for a and 12.3 MB for dL/da;
//     workspace 80 KB per pose; ActuationJacobian 198 MB (1,543,500 x 16 doubles) plus
//     12 MB of scratch.
//   per_element (no grid): 1,543,500 MLP outputs, 199,130,188 parameters = 1.59 GB per
//     parameter array (64 GB of L-BFGS history), which is why the grid exists: use
//     per_element for small meshes and tests.
//
// The grid keeps about one node per 500 elements here (factor 4); the count scales as
// volume / spacing^3 plus a boundary layer, so thin or curved bodies keep relatively
// more. Everything above the parameters scales with the element count and the batch.
//
// Immutable after construction; the const methods are thread-safe as long as each
// thread has its own workspace and gradient arrays.
class ActuationDecoder {
 public:
  // CHECKs latent_dim > 0, positive hidden widths and a positive, finite output_scale.
  ActuationDecoder(const DecoderSpec& spec, GridActuationField field);

  const DecoderSpec& spec() const { return spec_; }
  const Mlp& mlp() const { return mlp_; }
  const GridActuationField& field() const { return field_; }
  int latent_dim() const { return spec_.latent_dim; }
  int num_elements() const { return field_.num_elements(); }
  int num_nodes() const { return field_.num_nodes(); }
  int num_parameters() const { return mlp_.num_parameters(); }

  // Random initial parameters (Mlp::InitializeParameters): initial actuations deviate
  // from I by about output_scale x output_layer_gain (1% with the defaults).
  void InitializeParameters(unsigned seed, double* params,
                            double output_layer_gain = 0.1) const;

  // a(z) for one latent z (latent_dim): *a is resized to 6 x num_elements. Keeps in
  // *workspace what Backward() needs (a batch of one).
  void Decode(const double* params, const Eigen::Ref<const Eigen::VectorXd>& z,
              ActuationMatrix* a, DecoderWorkspace* workspace) const;
  // a(z_p) for the P columns of latents (latent_dim x P), in one batched MLP pass:
  // (*a)[p] (6 x num_elements) is pose p.
  void DecodeBatch(const double* params, const Eigen::Ref<const Eigen::MatrixXd>& latents,
                   std::vector<ActuationMatrix>* a, DecoderWorkspace* workspace) const;

  // Reverse mode for the batch of the last Decode/DecodeBatch with `workspace`, for a
  // scalar L of the actuations: dl_da[p] = dL/da(z_p) (6 x num_elements) for each pose.
  // ADDS dL/dparams to param_gradient (num_parameters(); the caller zeroes it) and, if
  // latent_gradient is not null, sets it to dL/dz (latent_dim x P, column p for pose p).
  void Backward(const double* params, const DecoderWorkspace& workspace,
                const std::vector<ActuationMatrix>& dl_da, double* param_gradient,
                Eigen::MatrixXd* latent_gradient) const;
  // The same for a batch of one (after Decode): dL/dz is latent_dim x 1.
  void Backward(const double* params, const DecoderWorkspace& workspace,
                const ActuationMatrix& dl_da, double* param_gradient,
                Eigen::MatrixXd* latent_gradient) const;

  // The Jacobian d a / d z at z: (6 num_elements) x latent_dim, column j = d a / d z_j
  // flattened column-major (element e's six numbers at rows 6e .. 6e+5), the layout
  // EquilibriumDifferentiator::ActuationJacobianProduct takes. Forward mode: latent_dim
  // directions through the MLP (Mlp::InputJacobian), then Interpolate per column.
  // Memory: the result (6 num_elements latent_dim doubles, 198 MB at 257,250 elements
  // and d = 16) plus 6 num_nodes latent_dim for the MLP's part. If a is not null it
  // receives a(z).
  Eigen::MatrixXd ActuationJacobian(const double* params,
                                    const Eigen::Ref<const Eigen::VectorXd>& z,
                                    ActuationMatrix* a = nullptr) const;

 private:
  DecoderSpec spec_;
  GridActuationField field_;
  Mlp mlp_;
};

// The memory a decoder with `spec` and `field` uses, by piece (see DecoderMemory), for
// batches of batch_size poses. Exact for arrays of doubles; excludes allocator and
// Eigen's small temporaries.
DecoderMemory DecoderMemoryBytes(const DecoderSpec& spec, const GridFieldDescription& field,
                                 int batch_size);
// The same from the counts alone (for planning, before a field exists): a field with
// num_elements elements and num_nodes control nodes (per_element: num_nodes =
// num_elements, no tables). Arithmetic in doubles: no overflow for any spec. The
// parameter count is *num_parameters (may be null).
DecoderMemory DecoderMemoryBytes(const DecoderSpec& spec, double num_elements, double num_nodes,
                                 bool per_element, double batch_size,
                                 double* num_parameters = nullptr);

// Decoder files (text; '#' starts a comment; blank lines are skipped). In order:
//
//   aqs_actuation_decoder 1
//   latent_dim <d>
//   hidden_dims <count> <width>...       (count may be 0)
//   activation <elu|tanh|softplus>
//   output_scale <s>
//   anchored <0|1>                       (optional: 0 if absent)
//   linear_skip <0|1>                    (optional: 0 if absent)
//   field <grid|per_element>
//   num_elements <E>
//   -- grid only:
//   origin <x> <y> <z>
//   spacing <h>
//   grid_dims <nx> <ny> <nz>
//   num_nodes <N>
//   <i> <j> <k>                          (N lines: GridFieldDescription::nodes, increasing
//                                         grid index)
//   -- always:
//   num_parameters <P>
//   <p>                                  (P lines, the Mlp layout; comments name the layers
//                                         and the skip weights)
//
// Real numbers are the shortest text that reads back exactly (util/number_format.h), so a
// saved and loaded decoder is bit for bit the same. About 21 bytes per parameter.

// Writes the file atomically (util/atomic_file.h). params must hold the parameter count
// of spec and field (CHECKed). Returns false with *error naming the file on failure.
bool SaveDecoder(const std::string& path, const DecoderSpec& spec,
                 const GridFieldDescription& field,
                 const Eigen::Ref<const Eigen::VectorXd>& params, std::string* error);

// Reads a file written by SaveDecoder. Returns false with *error as "path:line: what"
// on any malformed or inconsistent content (wrong keyword, count, non-number,
// non-positive size, nodes outside the grid or out of order, a parameter count that does
// not match the layer sizes, missing or extra lines). Rebuild the field with
// GridActuationField::FromDescription(mesh, *field, path, ...).
bool LoadDecoder(const std::string& path, DecoderSpec* spec, GridFieldDescription* field,
                 Eigen::VectorXd* params, std::string* error);

}  // namespace aqs

#endif  // AQS_LEARN_DECODER_H_
