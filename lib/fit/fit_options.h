#ifndef AQS_FIT_FIT_OPTIONS_H_
#define AQS_FIT_FIT_OPTIONS_H_

// What a fit takes (LatentFitter, fit/latent_fit.h): the options of every fit, of scan
// fits and of the start choice, each validated in one place (fit/fit_options.cc).

#include <string>

#include "equilibrium/quasistatic_solver.h"
#include "fit/fit_target.h"

namespace aqs {

struct LatentFitOptions {
  // The priors of the model (ActiveModel::fit_prior, learned from its training poses if
  // it has none): Gaussians over the latent and over each bone's 6 motion parameters,
  // centred on the neutral. Each adds residuals sqrt(weight / W) L^-1 (x - mean) to the
  // data residuals sqrt(w_k / W) (p_k - y_k), W = sum_k w_k (the number of target
  // points for markers, poses and scans; with matching rounds, the matched weight). The
  // weights are squared lengths in model units: the squared distance per target point
  // that one standard deviation of the prior is worth. So the priors weigh less against many
  // points than against a few markers, as a Bayesian posterior with that per-point
  // noise variance would (up to prior_points_cap). 0: off.
  // The bone prior's default, 0.01, was chosen on the demo's fit benchmark (docs/fitting.md,
  // 2026-12-01 third session): against 0.03 it tracks the marker sequence at 0.099 instead
  // of 0.137 and leaves the marker mixes, full-correspondence fits and scans within 1%.
  // The latent prior's default stays 0.03: at 0.01 the full face (latent 16) fits 20 / 60
  // markers closer (validation mixes 0.0949 -> 0.0802 / 0.0549 -> 0.0486) and the demo
  // (latent 8) as closely, but the demo's fit of ICT's mouthClose (lips pushed through
  // each other) then needs 263 s of contact instead of 11. Scans have their own weight
  // (PointCloudFitOptions::latent_prior; docs/fitting.md, "The latent prior's weight").
  double latent_prior = 0.03;
  double bone_prior = 0.01;
  // W in the priors' weights is at most this many points: target points are not
  // independent observations (the model's errors are correlated over the surface), so
  // thousands of scan or pose points must not make the priors vanish. <= 0: no cap.
  double prior_points_cap = 200;
  // Legacy isotropic prior: residual sqrt(latent_regularization) z (not scaled by the
  // number of points; what the latents were trained with). 0: off.
  double latent_regularization = 0.0;
  // Also fit the rigid motion of each bone of the model (6 numbers each: a rotation
  // vector and a translation of the bone's rest position). Otherwise bones stay where
  // set_bone_transforms put them.
  bool fit_bones = true;
  int max_iterations = 50;
  // Levenberg-Marquardt stops when the cost changes by less than this fraction in an
  // iteration (Ceres' function_tolerance) or the step is below parameter_tolerance
  // relative to the parameters.
  double function_tolerance = 1e-4;
  double parameter_tolerance = 1e-10;
  // A second start against the local minima of dense targets (poses with known
  // correspondence): Fit fits a point-to-point target of more than twice this many
  // points directly and also, from the same start, first to this many of its points
  // (FarthestPointSubset, target_subset.h) and then to all of them, and keeps the fit of
  // the smaller objective. The jaw's motion makes the objective non-convex; sparser data
  // can lead around a minimum that all points hold. On the demo's 40 benchmark mixes,
  // 200 points changed one fit (0.160 -> 0.096 cm) at three times the factorizations
  // (docs/fitting.md), so it is off by default. 0: directly only.
  int coarse_points = 0;
  // Also estimate how well the data determine the fit (LatentFitResult's
  // parameter_covariance, surface_std): the covariance of the fitted parameters, from
  // ceres::Covariance at the result, as the posterior of Gaussian data noise whose
  // per-residual variance is the fit's own (sigma^2 = sum_k w_k |p_k - y_k|^2 /
  // (residuals - parameters)), carried to each surface vertex through dx*/dparameters.
  // Costs one covariance of latent_dim + 6 per bone parameters; the products are the
  // last Jacobian's.
  bool uncertainty = false;
  QuasistaticSolverOptions solver;
  int num_threads = 2;

  // Checks every field; false with *error naming the first bad one.
  bool Validate(std::string* error) const;
  // What shapes a fit's result, as text (every field but num_threads; the solver's
  // QuasistaticSolverOptions::KeyText): the key of stored fits (aqs_evaluate's). A new
  // field that changes results belongs here.
  std::string KeyText() const;
};

// Options of point-cloud fitting (scans without correspondence).
struct PointCloudFitOptions {
  // Matching/fitting rounds: each matches every scan point to the closest point of the
  // current simulated surface, then refits with those correspondences fixed.
  int max_rounds = 8;
  int iterations_per_round = 6;
  // Scan points farther than this from the surface are ignored in that round (outliers,
  // parts the model does not cover). <= 0: no cap.
  double max_distance = 1.0;
  // Cauchy robust weights w = 1 / (1 + (d / robust_scale)^2) (iteratively reweighted
  // least squares); <= 0: plain least squares.
  double robust_scale = 0.2;
  // Stop when the mean matched distance changes by less than this fraction; rounds that
  // run out converge when the last round's solve changed it by less (one more matching).
  double relative_tolerance = 1e-3;
  // Point-to-plane residuals (FitTarget::normals, the matched triangle's normal) with
  // this weight on the tangential part; >= 1: point-to-point. (Matching rounds only.)
  double tangential_weight = 0.2;
  // One Levenberg-Marquardt solve whose residuals are the scan points' robust
  // distances to the surface, re-matched at every evaluation (see FitPointCloud),
  // instead of matching rounds with fixed correspondences.
  bool rematch_every_evaluation = true;
  // Landmarks: points of the scan whose place on the model's surface is known (e.g. the
  // eye and mouth corners a face tracker finds in the scan's image), fitted together
  // with the scan in both modes. Distances to a surface do not see motion along it (a
  // mouth that slides sideways); landmarks do. The objective adds
  //   landmark_weight (1/sum w) sum_k w_k |p_k - y_k|^2
  // (the target's points and weights), so with weight 1 the landmarks' mean squared
  // distance counts as much as the scan's. Empty (no points): none. The default was
  // chosen on the demo's validation scans with 10 landmarks of 0.1 cm noise, by the scans
  // within 1.2x of the fit with correspondence: 14 of 20 without landmarks; 14, 15, 10,
  // 6 and 3 with weights 0.01, 0.03, 0.1, 0.3 and 1 (docs/fitting.md). Landmarks are
  // where the model errs most, and a fit that holds them tightly bends the rest of the
  // face to them (weight 1 is worse even with exact landmarks). Many precise landmarks
  // are another matter: 60 markers the scan shows (0.02 cm noise) fit best at weight 1
  // (19 of 20 validation scans within 1.2x on both the demo and the full face).
  FitTarget landmarks;
  double landmark_weight = 0.03;
  // The bone prior of scan fits: its weight (< 0: LatentFitOptions::bone_prior's), and
  // it is centred on the bones the fit starts from (the training pose ChooseStart picks,
  // the given start, or a sequence's previous frame) instead of the prior's centre: the
  // training poses' bone motions as the modes of the prior, the start's mode the one
  // that holds. The start itself is chosen without it. A scan sees one side, and the
  // jaw's motion shows most where it does not look (under the chin): on the demo's
  // validation scans, 16 of 20 within 1.2x of the fit with correspondence (18 with
  // landmarks) against 14 (15) with the other fits' prior (docs/fitting.md). Centred on
  // the prior's centre, weight 0.1 held a scan's wide-open jaw shut (test mix_007).
  double bone_prior = 0.1;
  // The latent prior's weight in scan fits (< 0: LatentFitOptions::latent_prior's). A
  // scan's distances stay small wherever the surface can slide along it, so the prior
  // weighs more against a scan than against a pose or markers, and held scans near the
  // prior's centre. Chosen on the validation scans by those within 1.2x of the fit with
  // correspondence (demo + full face, without / with 10 landmarks): 0.03 (the other
  // fits') 16 + 1 / 18 + 2 of 20, 0.01 16 + 6 / 18 + 8, 0.003 15 + 9 / 16 + 9; the full
  // face's scans 0.0815 -> 0.0628 at 0.01, the demo's 0.0935 -> 0.0940 (docs/fitting.md).
  double latent_prior = 0.01;

  // Checks every field; false with *error naming the first bad one.
  bool Validate(std::string* error) const;
  // Every number above that shapes a scan fit's result, as one line of text (the
  // landmarks, data rather than options, are not in it): the key of stored fits (a
  // sequence's key.txt). A new field that changes results belongs here.
  std::string KeyText() const;
};

// The smallest robust_scale and max_distance a point-cloud fit takes (when on, > 0), in
// model sizes (ModelSize: the diagonal of the neutral's bounding box). Below, every scan
// point weighs alike and next to nothing (robust_scale 1e-300: the fit stays where it
// starts), or none is matched.
constexpr double kMinPointScaleInModelSizes = 1e-6;

// Checks options.robust_scale and options.max_distance against a model of size
// `model_size` (model units): each 0 (off) or at least kMinPointScaleInModelSizes model
// sizes. Returns false with *error naming the field ("points.robust_scale",
// "points.max_distance"), its value and the smallest it takes. Validate() checks the
// rest, without the model.
bool CheckPointCloudScales(const PointCloudFitOptions& options, double model_size,
                           std::string* error);

// Where fits start (LatentFitter::ChooseStart).
struct FitStartOptions {
  // Consider the training poses with a stored equilibrium (their latent, bone motions
  // and equilibrium) besides the given start, and start from whichever has the
  // smallest objective (the fit's data term plus priors; for scans, with the matching
  // of the first round).
  bool training_poses = true;
  // FitFromChosenStart (fit/chosen_start_fit.h): a fit from a training pose that fails,
  // does not converge, or ends with a bone farther from the prior's centre than any
  // training pose's and than one standard deviation (Mahalanobis distance under the bone
  // prior) is fitted again from the given start, and the fit of the smaller objective
  // kept. On the demo's surface-
  // latent model, two full-correspondence fits from jawOpen went on to a 25 degree jaw
  // (0.231 and 0.160 cm, 224 and 142 s), where fits from the given start reach 0.101 and
  // 0.053 in 2 s (docs/fitting.md).
  bool retry_from_given = true;
  // The given start of aqs_fit and the benchmark: the mean of the training latents
  // (what fits did before priors) instead of the latent prior's centre.
  bool mean_latent = false;
};

}  // namespace aqs

#endif  // AQS_FIT_FIT_OPTIONS_H_
