#ifndef AQS_JOBS_EVALUATE_JOB_H_
#define AQS_JOBS_EVALUATE_JOB_H_

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "eval/surface_autoencoder.h"
#include "fit/latent_fit.h"
#include "jobs/evaluation_report.h"
#include "prepare/volumetric_targets.h"

namespace aqs {

class Communicator;

// What aqs_evaluate does: compare, on the training poses and on held-out ones, the
// physics-based model with two surface-only baselines of the same latent size.
struct EvaluateJobOptions {
  std::string model;                    // trained model directory; required
  std::vector<std::string> test_paths;  // held-out pose surfaces (OBJ, the neutral's order)
  std::string output_directory;         // tables and fields; required
  // The surface vertices the errors are measured on (empty: all). For a face, the face
  // region (the head's back never moves and would dilute the means).
  std::vector<int> error_vertices;
  LatentFitOptions fit;                 // fitting held-out poses with the physics model
  // Where the latent fits of held-out poses start, for the physics model and the
  // auto-encoder alike. false: the mean training latent (physics: bones at rest, from the
  // rest shape). true: the best of that start and every training pose's latent, by the
  // fit's own objective (physics: LatentFitter::ChooseStart, with the pose's bone
  // motions and stored equilibrium; auto-encoder: its trained latents, by FitLatent's
  // objective). The report names each fit's start.
  bool training_pose_starts = true;
  // The surface auto-encoder baseline (its latent_dim, hidden layers and activation are
  // set from the model's decoder; iterations etc. from here).
  SurfaceAutoencoderOptions autoencoder;
  // The auto-encoder's hidden layer widths where they should not be the decoder's (each
  // > 0). For a linear decoder (no hidden layers) the auto-encoder should keep a
  // network: a linear auto-encoder anchored at the neutral spans what the PCA about the
  // neutral spans, which the comparison has already. Unset: the decoder's.
  std::optional<std::vector<int>> autoencoder_hidden_dims;
  // Whether the auto-encoder has a linear skip beside its network, where it should not
  // follow the decoder (on the demo face the skip makes the auto-encoder worse on
  // held-out poses, so a decoder with a skip is compared with the auto-encoder without
  // one). Unset: the decoder's.
  std::optional<bool> autoencoder_linear_skip;
  // Write per-vertex error fields (PLY with colours and a `value` property) for each
  // held-out pose and method, and the fitted surfaces (OBJ).
  bool write_fields = true;
  // The error budget (eval/error_budget.h): for the training poses, (a) the floor (each
  // pose's volumetric target simulated, from rest; again from the stored training
  // equilibrium where that fails) and (b) the surface error after pre-training (read
  // from the model's pretrain/surface_errors.*, where recorded); for each held-out
  // pose, the floor of its own volumetric target: prepare's embedded simulation
  // (held_out_targets) with the bones where the physics fit put them, then the target
  // simulated. The equilibria use fit.solver's tolerance.
  bool error_budget = true;
  // Work whose memory is estimated before it is allocated (the auto-encoder baseline) is
  // refused above this many bytes.
  double max_memory_bytes = 8e9;
  VolumetricTargetOptions held_out_targets;
  // The pictures and the HTML page (index.html) by an external script, run at the end
  // as `python report_script --evaluation <output_directory> --model <model>`
  // (scripts/evaluation_report.py). Empty report_script: none. Its failure (python or
  // matplotlib missing, or any other) is logged; the tables are written before it.
  std::string report_script;
  std::string python = "python3";
  int num_threads = 2;
  // Distributed evaluation (docs/distributed.md): every rank of the communicator calls
  // RunEvaluateJob with the same options; the physics fits of the held-out poses are
  // shared among the ranks (pose t on rank t % size), and rank 0 does the rest and
  // writes every output. Null (or one rank): one process.
  const Communicator* communicator = nullptr;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// The folder of the auto-encoder baseline's training checkpoints in the output folder.
inline constexpr char kAutoencoderCheckpointFolder[] = "autoencoder_checkpoint";
// The folder of the held-out physics fits kept as they are made, in the output folder.
inline constexpr char kHeldOutFitFolder[] = "held_out_fits";

// Runs the evaluation: trains the baselines on the model's training poses, measures
// all three methods on the training poses (physics: its training latents and bone
// motions, re-simulated; autoencoder: its training latents; PCA: projection) and on the
// held-out poses (physics: latent and bone motion fitted to all vertices, LatentFitter;
// autoencoder: latent fitted, SurfaceAutoencoder::FitLatent; PCA: projection), and
// writes <output>/evaluation.md (a table per split with per-pose rows and means; the
// neutral surface's error is a reference column; with error_budget, the budget tables),
// <output>/evaluation.csv, and, with write_fields, <output>/fields/<pose>_<method>.ply
// and <output>/fitted/<pose>_<method>.obj for the held-out poses (methods physics,
// autoencoder, pca, pca_neutral, and floor with error_budget; fitted/<pose>_target.obj is the pose
// itself); with write_fields and error_budget also <output>/budget/training_errors.bin
// (util/matrix_io.h, num_surface_vertices x 3 num_poses: per training pose in the
// model's order the per-vertex errors of the floor, after pre-training and trained; NaN
// where not measured). Then runs the report script if set. Returns false with *error
// on bad input. While the auto-encoder baseline trains, its checkpoints go to
// <output>/kAutoencoderCheckpointFolder (train/solver_checkpoint.h), and the held-out
// physics fits are kept in <output>/kHeldOutFitFolder as they are made
// (jobs/held_out_fits.h): a rerun after a stop resumes the baseline's training and
// takes the fits already made; both folders are removed once the tables are written. Each
// held-out pose's physics fit starts from rest with a fitter of its
// own, so its result does not depend on the other poses nor on which rank fits it: a
// distributed run writes the same outputs as one process with the same thread counts.
// Distributed: rank 0 logs and writes; every rank returns the same status, with
// *error on every rank (naming the rank) for failures up to the fits and on rank 0
// after them.
bool RunEvaluateJob(const EvaluateJobOptions& options, std::ostream& log,
                    std::vector<EvaluationRow>* rows, std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_EVALUATE_JOB_H_
