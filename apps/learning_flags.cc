#include "learning_flags.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <gflags/gflags.h>

#include "app_common.h"
#include "util/line_reader.h"
#include "util/number_format.h"

DEFINE_int32(latent_dim, 16, "Latent dimension d.");
DEFINE_string(hidden, "128,128", "Hidden layer widths of the decoder (comma-separated).");
DEFINE_string(activation, "elu", "Hidden activation: elu, tanh or softplus.");
DEFINE_double(output_scale, 0.1,
              "Decoder output scale (a = I + field(scale * mlp(z))), in [1e-6, 1e6].");
DEFINE_bool(anchored_decoder, false, "Anchor the decoder at the origin: a(z) = I + field(scale * "
            "(mlp(z) - mlp(0))), so that the zero latent decodes to the rest shape exactly and "
            "the latent prior pulls towards it (the evaluation's auto-encoder follows).");
DEFINE_bool(linear_skip, false, "Give the decoder a linear part beside its network: a(z) = I + "
            "field(scale * (mlp(z) + W z)) (the evaluation's auto-encoder follows).");
DEFINE_double(grid_spacing, 0.0, "Spacing of the decoder's control grid (model units); 0: "
              "--grid_spacing_factor x the mean element edge.");
DEFINE_double(grid_spacing_factor, 4.0, "Control grid spacing in mean element edges.");
DEFINE_bool(per_element, false, "One decoder output per element instead of a control grid "
            "(small meshes only).");
DEFINE_double(latent_regularization, 1e-3, "Weight of the latent regularizer (1/P) sum |z|^2.");
DEFINE_double(decoder_regularization, 0.0,
              "Weight of the decoder regularizer |params|^2 (weight decay on the decoder's "
              "weights and biases), in pre-training and training. 0: none.");
DEFINE_double(energy_regularization, 0.0,
              "Weight of the equilibrium-energy regularizer of end-to-end training: each "
              "pose's elastic energy at equilibrium over sum mu V (a mean squared mismatch "
              "of F and the targets), averaged over the poses. Penalizes actuations that "
              "fight each other (pre-stress near buckling). 0: none.");
DEFINE_int32(pretrain_iterations, 500, "L-BFGS iterations of pre-training.");
DEFINE_double(pretrain_minutes, 0.0, "Stop pre-training after this many minutes of its "
              "iterations, keeping the point reached (0: no limit).");
DEFINE_double(pretrain_checkpoint_seconds, 60.0, "Pre-training saves a checkpoint (pretrain/ in "
              "the model) at most every this many seconds of its iterations, and at its end; "
              "a run killed between them resumes from the last (0: every iteration).");
DEFINE_string(pretrain_latents, "targets", "Where pre-training's latents start: 'targets' (the "
              "volumetric targets' principal components, fitted with the decoder) or 'surfaces' "
              "(the pose surfaces' principal components about the neutral, held while the "
              "decoder is fitted to them).");
DEFINE_uint32(seed, 1, "Seed of the decoder's initial weights.");
DEFINE_int32(train_iterations, 200, "L-BFGS iterations of end-to-end training (in all, counting "
             "a resumed run's earlier ones).");
DEFINE_double(train_minutes, 0.0, "Stop end-to-end training after this many minutes of this run "
              "(0: no limit).");
DEFINE_double(train_tolerance, 1e-6, "Relative force tolerance of the training equilibria.");
DEFINE_bool(pretrain_simulate, true, "After pre-training, simulate every pose's pre-trained "
            "latent (from rest, at --train_tolerance): logs and stores the surface error after "
            "pre-training (pretrain/surface_errors.*, the error budget's stage (b)) and gives "
            "training its starting equilibria.");
DEFINE_int32(checkpoint_every, 1, "Save the learned state at the multiples of this many "
             "iterations (counted over all runs of the model), and where a run ends.");
DEFINE_double(factor_cache_gb, 4.0, "End-to-end training keeps one stiffness factor per pose (far "
              "fewer factorizations) while the poses' factors take at most this many GB in all "
              "(per process), else one solver per thread with single-precision copies of as many "
              "poses' factors as this many GB hold.");
DEFINE_bool(line_search_starts, true, "End-to-end training starts a line-search trial's solves "
            "from the equilibria of two earlier evaluations on the trial's line, interpolated, "
            "where that start is closer to equilibrium than the last evaluation's.");
DEFINE_bool(lbfgs_scaling, true, "End-to-end training: L-BFGS' initial inverse Hessian is "
            "s'y / y'y of the last step times I (Ceres' use_approximate_eigenvalue_bfgs_scaling) "
            "instead of I, so that a step has the scale of the loss' curvature.");
DEFINE_double(adjoint_tolerance, 1e-10, "End-to-end training: relative residual of the adjoint "
              "solves done by conjugate gradients on an earlier stiffness factor, in [1e-14, "
              "0.01]; the gradient is off by about that fraction.");
DEFINE_int32(train_restarts, 50, "L-BFGS restarts allowed when the line search stalls before the "
             "iteration or time budget is used: end-to-end training's, pre-training's and the "
             "evaluation's auto-encoder baseline's (one rule for all).");
DEFINE_int32(latent_refit_iterations, 0, "End-to-end training: before the first iteration (not "
             "when resuming), refit every pose's latent alone, decoder fixed, by this many "
             "Levenberg-Marquardt iterations on its share of the loss (0: no refits; under mpirun "
             "each rank refits the poses it owns).");
DEFINE_int32(latent_refit_every, 0, "With --latent_refit_iterations: refit again after every this "
             "many iterations (0: only before the first).");
DECLARE_int32(threads);

namespace aqs {

namespace {

bool HiddenFromFlag(std::vector<int>* widths, std::string* error) {
  widths->clear();
  // An empty list is a decoder without hidden layers; an empty item is a typo.
  const std::vector<std::string> items = SplitList(FLAGS_hidden);
  if (static_cast<size_t>(std::count(FLAGS_hidden.begin(), FLAGS_hidden.end(), ',')) + 1 !=
          items.size() &&
      !FLAGS_hidden.empty()) {
    *error = "--hidden has an empty width in '" + FLAGS_hidden + "'";
    return false;
  }
  for (const std::string& item : items) {
    int width = 0;
    if (!ParseInt(item, &width) || width < 1) {
      *error = "--hidden takes positive widths, got '" + item + "'";
      return false;
    }
    widths->push_back(width);
  }
  return true;
}

bool ActivationFromFlag(Activation* activation, std::string* error) {
  if (!ActivationFromName(FLAGS_activation, activation)) {
    *error = "--activation must be elu, tanh or softplus, got '" + FLAGS_activation + "'";
    return false;
  }
  return true;
}

bool IsDefault(const char* flag) { return gflags::GetCommandLineFlagInfoOrDie(flag).is_default; }

}  // namespace

bool PretrainOptionsFromFlags(PretrainOptions* options, std::string* error) {
  options->spec.latent_dim = FLAGS_latent_dim;
  if (!HiddenFromFlag(&options->spec.hidden_dims, error) ||
      !ActivationFromFlag(&options->spec.activation, error)) {
    return false;
  }
  options->spec.output_scale = FLAGS_output_scale;
  options->spec.anchored = FLAGS_anchored_decoder;
  options->spec.linear_skip = FLAGS_linear_skip;
  options->field.node_spacing = FLAGS_grid_spacing;
  options->field.node_spacing_factor = FLAGS_grid_spacing_factor;
  options->field.per_element = FLAGS_per_element;
  options->latent_regularization = FLAGS_latent_regularization;
  options->decoder_regularization = FLAGS_decoder_regularization;
  options->max_iterations = FLAGS_pretrain_iterations;
  options->max_restarts = FLAGS_train_restarts;
  // In minutes, the flag's unit: 1e307 minutes are inf seconds.
  if (!(FLAGS_pretrain_minutes >= 0) || !std::isfinite(60.0 * FLAGS_pretrain_minutes)) {
    *error = "--pretrain_minutes must be finite and >= 0 (is " +
             FormatDouble(FLAGS_pretrain_minutes) + ")";
    return false;
  }
  options->max_seconds = 60.0 * FLAGS_pretrain_minutes;
  options->checkpoint_seconds = FLAGS_pretrain_checkpoint_seconds;
  if (!PretrainLatentStartFromName(FLAGS_pretrain_latents, &options->latent_start)) {
    *error = "--pretrain_latents must be targets or surfaces, got '" + FLAGS_pretrain_latents + "'";
    return false;
  }
  options->seed = FLAGS_seed;
  options->max_memory_bytes = MaxMemoryBytes();
  return true;
}

bool PretrainSimulationFromFlags(PoseSimulationOptions* options, bool* enabled,
                                 std::string* error) {
  *enabled = FLAGS_pretrain_simulate;
  options->solver.relative_force_tolerance = FLAGS_train_tolerance;
  options->num_threads = FLAGS_threads;
  return SolverMethodFromFlag(&options->solver, error);
}

bool ExpectedDecoderFromFlags(ExpectedDecoder* expected, std::string* error) {
  *expected = ExpectedDecoder();
  if (!IsDefault("latent_dim")) expected->latent_dim = FLAGS_latent_dim;
  if (!IsDefault("hidden") && !HiddenFromFlag(&expected->hidden_dims, error)) return false;
  if (!IsDefault("activation")) {
    Activation activation;
    if (!ActivationFromFlag(&activation, error)) return false;
    expected->activation = ActivationName(activation);
  }
  return true;
}

FlagNames PretrainFlagNames() {
  FlagNames flags = CommonFlagNames();
  const FlagNames simulation = CommonFlagNames("simulation.");
  flags.insert(flags.end(), simulation.begin(), simulation.end());
  flags.insert(flags.end(),
               {{"spec.latent_dim", "--latent_dim"},
                {"spec.hidden_dims", "--hidden"},
                {"spec.output_scale", "--output_scale"},
                {"field.node_spacing", "--grid_spacing"},
                {"field.node_spacing_factor", "--grid_spacing_factor"},
                {"latent_regularization", "--latent_regularization"},
                {"decoder_regularization", "--decoder_regularization"},
                {"max_iterations", "--pretrain_iterations"},
                {"max_seconds", "--pretrain_minutes"},
                {"checkpoint_seconds", "--pretrain_checkpoint_seconds"},
                {"max_restarts", "--train_restarts"},
                {"simulation.solver.relative_force_tolerance", "--train_tolerance"}});
  return flags;
}

FlagNames TrainFlagNames() {
  FlagNames flags = CommonFlagNames();
  flags.insert(flags.end(), {{"latent_regularization", "--latent_regularization"},
                             {"decoder_regularization", "--decoder_regularization"},
                             {"energy_regularization", "--energy_regularization"},
                             {"max_iterations", "--train_iterations"},
                             {"max_seconds", "--train_minutes"},
                             {"solver.relative_force_tolerance", "--train_tolerance"},
                             {"checkpoint_every", "--checkpoint_every"},
                             {"max_restarts", "--train_restarts"},
                             {"max_factor_cache_gb", "--factor_cache_gb"},
                             {"adjoint_tolerance", "--adjoint_tolerance"},
                             {"latent_refit_every", "--latent_refit_every"},
                             {"latent_refit_iterations", "--latent_refit_iterations"},
                             {"latent_dim", "--latent_dim"},
                             {"hidden_dims", "--hidden"},
                             {"activation", "--activation"}});
  return flags;
}

bool TrainOptionsFromFlags(TrainOptions* options, std::string* error) {
  options->max_factor_cache_gb = FLAGS_factor_cache_gb;
  options->line_search_starts = FLAGS_line_search_starts;
  options->adjoint_tolerance = FLAGS_adjoint_tolerance;
  options->lbfgs_scaling = FLAGS_lbfgs_scaling;
  options->latent_regularization = FLAGS_latent_regularization;
  options->decoder_regularization = FLAGS_decoder_regularization;
  options->energy_regularization = FLAGS_energy_regularization;
  options->max_iterations = FLAGS_train_iterations;
  if (!(FLAGS_train_minutes >= 0) || !std::isfinite(60.0 * FLAGS_train_minutes)) {
    *error = "--train_minutes must be finite and >= 0 (is " + FormatDouble(FLAGS_train_minutes) +
             ")";  // here, in minutes: max_seconds' check would print seconds
    return false;
  }
  options->max_seconds = 60.0 * FLAGS_train_minutes;
  options->solver.relative_force_tolerance = FLAGS_train_tolerance;
  if (!SolverMethodFromFlag(&options->solver, error)) return false;
  options->num_threads = FLAGS_threads;
  options->checkpoint_every = FLAGS_checkpoint_every;
  options->max_restarts = FLAGS_train_restarts;
  options->latent_refit_every = FLAGS_latent_refit_every;
  options->latent_refit_iterations = FLAGS_latent_refit_iterations;
  return true;
}

}  // namespace aqs
