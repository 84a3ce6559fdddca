#ifndef AQS_JOBS_EVALUATE_JOB_H_
#define AQS_JOBS_EVALUATE_JOB_H_

#include <ostream>
#include <string>
#include <vector>

#include "eval/surface_autoencoder.h"
#include "fit/latent_fit.h"

namespace aqs {

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
  // The surface auto-encoder baseline (its latent_dim, hidden layers and activation are
  // set from the model's decoder; iterations etc. from here).
  SurfaceAutoencoderOptions autoencoder;
  // Write per-vertex error fields (PLY with colours and a `value` property) for each
  // held-out pose and method, and the fitted surfaces (OBJ).
  bool write_fields = true;
  int num_threads = 2;
};

// One row of the evaluation: the vertex distances of one method on one pose.
struct EvaluationRow {
  std::string split;   // "train" or "test"
  std::string pose;
  std::string method;  // "neutral" (the rest surface, for reference), "physics", "autoencoder", "pca"
  double mean = 0.0, rms = 0.0, max = 0.0;
};

// Runs the evaluation: trains the baselines on the model's training poses, measures
// all three methods on the training poses (physics: its training latents and bone
// motions, re-simulated; autoencoder: its training latents; PCA: projection) and on the
// held-out poses (physics: latent and bone motion fitted to all vertices, LatentFitter;
// autoencoder: latent fitted, SurfaceAutoencoder::FitLatent; PCA: projection), and
// writes <output>/evaluation.md (a table per split with per-pose rows and means; the
// neutral surface's error is a reference column),
// <output>/evaluation.csv, and, with write_fields, <output>/fields/<pose>_<method>.ply
// and <output>/fitted/<pose>_<method>.obj. Returns false with *error on bad input.
bool RunEvaluateJob(const EvaluateJobOptions& options, std::ostream& log,
                    std::vector<EvaluationRow>* rows, std::string* error);

// Parses "a:b" (vertices a to b-1), "a-b" (a to b) or a comma list of such, e.g.
// "0:9409". Returns false with *error.
bool ParseVertexRanges(const std::string& text, std::vector<int>* vertices, std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_EVALUATE_JOB_H_
