#ifndef AQS_JOBS_EVALUATION_REPORT_H_
#define AQS_JOBS_EVALUATION_REPORT_H_

// What aqs_evaluate writes of its measurements (jobs/evaluate_job.h makes them): the
// rows of evaluation.csv and the tables and text of evaluation.md.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// How the report names the start of a held-out fit at the mean training latent.
constexpr char kMeanLatentStart[] = "mean latent";

// LatentFitResult::start of a held-out fit that failed (the report says the fit failed).
inline constexpr const char* kFailedFitStart = "failed";

// One row of the evaluation: the vertex distances of one method on one pose.
struct EvaluationRow {
  std::string split;   // "train" or "test"
  std::string pose;
  // "neutral" (the rest surface, for reference), "physics", "autoencoder", "pca",
  // "pca_neutral"; the error budget's "floor" (training and held-out poses) and
  // "pretrain" (training).
  std::string method;
  double mean = 0.0, rms = 0.0, max = 0.0;
};

// The methods compared, in the tables' order (pca_neutral: PCA about the neutral,
// uncentered displacements, the linear model whose zero is the rest, like an anchored
// decoder's), and the reference row of every pose: the neutral surface itself.
constexpr int kNumEvaluationMethods = 4;
extern const char* const kEvaluationMethods[kNumEvaluationMethods];
extern const char* const kNeutralMethod;

// Per-vertex distances |a_i - b_i| of two surfaces (3 x N each): N values.
Eigen::VectorXd VertexErrors(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b);

// The row of `errors` (one per surface vertex) over `vertices` (empty: all): mean, root
// mean square and largest.
EvaluationRow SummarizeErrors(const std::string& split, const std::string& pose,
                              const std::string& method, const Eigen::VectorXd& errors,
                              const std::vector<int>& vertices);

// The decimals the tables print every error of `rows` with (all splits, so that the
// tables of one evaluation agree): three significant digits at the median of the rows'
// positive means (4 for errors of 0.01 to 0.1, as a face in cm has; 6 for one in
// metres), at least kMinTableDecimals and at most kMaxTableDecimals.
inline constexpr int kMinTableDecimals = 4;
inline constexpr int kMaxTableDecimals = 12;
int TableDecimals(const std::vector<EvaluationRow>& rows);

// The Markdown table of one split ("train", "test"): per pose the neutral's mean and
// every method's mean, rms and max, then the means over poses (max: the largest), with
// TableDecimals(rows) decimals. Empty if the split has no rows.
std::string EvaluationTable(const std::vector<EvaluationRow>& rows, const std::string& split);

// The error budget as Markdown: per pose the mean error of each stage, then the mean
// over poses and the largest vertex error (TableDecimals(rows) decimals). `columns`:
// (method, heading) in order; a method without a row for a pose shows "n/a" (and its
// mean "n/a"). Empty if the split has no rows.
std::string ErrorBudgetTable(const std::vector<EvaluationRow>& rows, const std::string& split,
                             const std::vector<std::pair<std::string, std::string>>& columns);

// What the evaluation compared and how, for evaluation.md's text.
struct EvaluationReportParts {
  std::string model;           // the model's directory
  int num_error_vertices = 0;  // vertices the errors are measured over
  int latent_dim = 0;
  int num_bones = 0;  // the physics model's bones (6 rigid parameters each)
  // Held-out floors left out because the pose's physics fit failed (with bones).
  int floor_without_fit = 0;
  // Training poses whose (b) equilibrium did not converge when pre-training ended.
  int pretrain_unconverged = 0;
  // End-to-end training iterations of the model (0: pre-trained only; (c) is then (b)).
  int trained_iterations = -1;
  // The physics decoder's and the auto-encoder's layouts.
  std::vector<int> decoder_hidden_dims, autoencoder_hidden_dims;
  bool decoder_anchored = false;
  bool decoder_linear_skip = false, autoencoder_linear_skip = false;
  // The auto-encoder's training: iterations, L-BFGS restarts after a stall (in the last
  // run), loss before and after, why it stopped.
  int autoencoder_iterations = 0;
  int autoencoder_restarts = 0;
  // > 0: its training resumed an earlier, stopped run's checkpoint after this many
  // iterations. If it trained on from there (autoencoder_iterations > this), L-BFGS'
  // memory started empty, so the result differs a little from an uninterrupted run's;
  // otherwise the checkpoint was the finished training and the result is that run's.
  int autoencoder_resumed_after = 0;
  // Held-out physics fits taken from a stopped run's store (jobs/held_out_fits.h).
  int physics_fits_kept = 0;
  bool autoencoder_scaled_steps = false;
  int autoencoder_seed = 0;
  double autoencoder_initial_loss = 0.0, autoencoder_final_loss = 0.0;
  double autoencoder_resumed_loss = 0.0;  // at the checkpoint resumed (resumed_after > 0)
  std::string autoencoder_termination;
  int pca_components = 0, pca_neutral_components = 0;
  // The latent priors of the held-out fits, the same for the physics model and the
  // auto-encoder (LatentFitOptions' latent_prior, prior_points_cap and legacy
  // latent_regularization), each with its Gaussian learned from its own training latents.
  double latent_prior = 0.0, prior_points_cap = 0.0, fit_latent_regularization = 0.0;
  // Held-out poses that are training poses (empty: none).
  std::string overlap_note;
  // Held-out poses, in order, and where each one's physics and auto-encoder latent fits
  // started; whether starts were chosen among the training poses.
  std::vector<std::string> test_names, physics_starts, autoencoder_starts;
  bool training_pose_starts = true;
  // The error budget: whether it was made, whether the pre-training stage (b) was
  // recorded, whether the held-out floor was made, and how many floor equilibria failed.
  bool error_budget = false;
  bool have_pretrain = false, have_held_out_floor = false;
  int floor_failures = 0;
  // Held-out poses whose physics fit failed (left out: n/a).
  int fit_failures = 0;
};

// evaluation.md's parts: the training and held-out tables (EvaluationTable) and the
// error budget's section (empty without error_budget).
struct EvaluationTables {
  std::string train, test, budget;
};
EvaluationTables MakeEvaluationTables(const std::vector<EvaluationRow>& rows,
                                      const EvaluationReportParts& parts);

// evaluation.md: what was compared, the starts of the held-out fits, the tables and the
// error budget.
std::string EvaluationMarkdown(const EvaluationReportParts& parts, const EvaluationTables& tables);

// evaluation.csv: "split,pose,method,mean,rms,max" and one line per row (17 digits).
std::string EvaluationCsv(const std::vector<EvaluationRow>& rows);

}  // namespace aqs

#endif  // AQS_JOBS_EVALUATION_REPORT_H_
