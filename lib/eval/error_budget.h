#ifndef AQS_EVAL_ERROR_BUDGET_H_
#define AQS_EVAL_ERROR_BUDGET_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "equilibrium/quasistatic_solver.h"
#include "geometry/rigid_transform.h"
#include "model/active_model.h"
#include "physics/actuation.h"

namespace aqs {

// The error budget of a physics model: how far its simulated surface is from a pose at
// each stage of learning, per surface vertex.
//
//   floor      the pose's own volumetric target simulated (what a decoder that reproduced
//              the targets exactly would reach on this simulation mesh and embedding; a
//              reference, not a lower bound: other actuations may come closer);
//   pretrain   the pre-trained decoder's actuation of the pose's latent, simulated (the
//              decoder was fitted to the targets, not to the surfaces);
//   trained    the end-to-end trained model, simulated.
//
// The differences between stages say what holds the model back: floor - 0 is the mesh
// and embedding, pretrain - floor what the decoder misses of the targets, and trained the
// result of optimizing through the simulator.

// |a.col(i) - b.col(i)| for every column (a and b 3 x N): N distances.
Eigen::VectorXd VertexDistances(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b);

// Mean, root mean square and max of `distances` over `vertices` (all if empty).
struct DistanceSummary {
  double mean = 0.0, rms = 0.0, max = 0.0;
};
DistanceSummary SummarizeDistances(const Eigen::VectorXd& distances,
                                   const std::vector<int>& vertices);

struct PoseSimulationOptions {
  QuasistaticSolverOptions solver;  // num_threads is set to 1: poses run in parallel
  int num_threads = 2;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// One simulated pose.
struct SimulatedPose {
  bool converged = false;
  std::string message;       // the solver's summary when it did not converge
  Eigen::Matrix3Xd state;    // the equilibrium reached (3 x num_vertices), even unconverged
  Eigen::Matrix3Xd surface;  // its embedded surface (3 x num_surface_vertices)
};

// Equilibria of the model's mesh under actuations[k] (6 x num_elements) with the
// model's bones at bone_transforms[k] (one per model bone), solved from the rest shape
// and, where that does not converge and start_states[k] is given (3 x num_vertices), again
// from start_states[k]. start_states may be empty. Poses run in parallel, one solver per
// thread; the result does not depend on the thread count.
std::vector<SimulatedPose> SimulateActuations(
    const ActiveModel& model, const std::vector<ActuationMatrix>& actuations,
    const std::vector<std::vector<RigidTransform>>& bone_transforms,
    const std::vector<Eigen::Matrix3Xd>& start_states, const PoseSimulationOptions& options);

// The bone transforms of training pose p (one per model bone).
std::vector<RigidTransform> TrainingPoseBones(const ActiveModel& model, int p);

// The decoder's actuation of every training latent (model.decoder set; CHECK).
std::vector<ActuationMatrix> DecodeTrainingLatents(const ActiveModel& model);

// What pre-training reached, simulated: per training pose the distances of every surface
// vertex to the pose surface, and whether the equilibrium converged. Stored in the model
// directory as pretrain/surface_errors.bin (num_surface_vertices x num_poses,
// util/matrix_io.h) and pretrain/surface_errors.txt (one line per pose: `index name
// mean max converged`, for people); docs/model_format.md.
struct PretrainSurfaceErrors {
  Eigen::MatrixXd distances;   // num_surface_vertices x num_poses
  std::vector<int> converged;  // per pose 0/1
};

// Writes both files (atomically, the text file last). Returns false with *error.
bool WritePretrainSurfaceErrors(const std::string& model_directory, const ActiveModel& model,
                                const PretrainSurfaceErrors& errors, std::string* error);
// Reads them for `model`. Returns false with *error empty if the model directory has no
// record (pre-trained without it), and with *error naming the file if a file is
// malformed or does not match the model (counts, pose names).
bool ReadPretrainSurfaceErrors(const std::string& model_directory, const ActiveModel& model,
                               PretrainSurfaceErrors* errors, std::string* error);

// The budget of the training poses as a plain-text table for logs: per pose the mean and
// max distance over all surface vertices at each stage available (the embedding floor
// from poses.txt, `pretrain` if given, and the distances of `trained_surfaces` if not
// empty: 3 x num_surface_vertices per pose), then the means over poses ("n/a" for
// stage (b) if a pose's equilibrium after pre-training did not converge).
std::string TrainingBudgetTable(const ActiveModel& model, const PretrainSurfaceErrors* pretrain,
                                const std::vector<Eigen::Matrix3Xd>& trained_surfaces);

}  // namespace aqs

#endif  // AQS_EVAL_ERROR_BUDGET_H_
