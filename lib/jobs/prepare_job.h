#ifndef AQS_JOBS_PREPARE_JOB_H_
#define AQS_JOBS_PREPARE_JOB_H_

#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dist/communicator.h"
#include "geometry/plane_cuts.h"
#include "geometry/surface_tet_mesher.h"
#include "prepare/boundary_rules.h"
#include "prepare/halfway_poses.h"
#include "prepare/mirror_poses.h"
#include "prepare/volumetric_targets.h"
#include "util/job_status.h"
#include "util/memory_limit.h"

namespace aqs {

// What aqs_prepare does: from a neutral surface and pose surfaces (same vertex order),
// build an ActiveModel (simulation mesh, boundary conditions, embedding, volumetric
// targets per pose) and save it.
struct PrepareJobOptions {
  std::string neutral;                  // neutral surface (OBJ); required
  std::vector<std::string> pose_paths;  // pose surfaces (OBJ), same vertex order; >= 1
  // The simulation mesh: a user tet mesh (any ReadTetMesh format), or else a lattice
  // over the inside of the neutral surface (`meshing`).
  std::string tet_mesh;
  SurfaceTetMeshOptions meshing;
  // Elements whose centroid lies outside all these boxes are dropped (none: keep all).
  std::vector<Eigen::AlignedBox3d> keep_boxes;
  // Planar cuts (geometry/plane_cuts.h) where surface parts touch and must part (lips,
  // eyelids); the embedding puts surface vertices on their side of each cut.
  std::vector<PlaneCut> cuts;
  // Within this distance of a cut, a surface vertex's side is the one its normal faces
  // away from (see AssignEmbeddingSides).
  double cut_margin = 0.0;
  // After meshing and cropping, elements at vertices that fewer elements hold are
  // removed (mesh/element_subset.h, PruneWeaklyHeldElements; 0 or 1: none).
  int min_elements_per_vertex = 4;
  double mu = 1.0;  // the material's stiffness, in [1e-12, 1e12]
  BoundaryRuleOptions boundary;
  // Mirror images of the poses (prepare/mirror_poses.h; axis -1: none): appended after
  // the given poses as "mirror_NAME", with their bones' motions mirrored.
  MirrorOptions mirror;
  // Halfway poses (prepare/halfway_poses.h): appended after the given poses and their
  // mirror images as "half_NAME", for the poses whose bones move.
  HalfwayOptions halfway;
  VolumetricTargetOptions targets;
  std::string output;                   // model directory; required
  // Replace whatever is at `output`; without it, only a missing path, an empty
  // directory or an ActiveQS model is replaced, and anything else is refused at once.
  bool overwrite = false;
  // Keep the model at `output` when it is the model this job would make: the same
  // mesh, material, fixed vertices, bones, embedding and poses (ModelFingerprint of the
  // model built, before its targets) and targets made with the same options, all
  // converged (ActiveModel::target_key). Then nothing is written, and the model keeps its
  // learned state and checkpoints. Another model that holds a learned state (a decoder)
  // is not replaced: the job fails with what differs (bad input), so that work is not
  // discarded without being asked (overwrite = false does not ask for it: it concerns
  // what is not a model). An unreadable model, or one not pre-trained, is prepared anew.
  // aqs_pipeline sets it, so that a rerun after a stop goes on where it stopped (not
  // with --restart).
  bool keep_same_model = false;
  int num_threads = 2;
  // The ranks of a distributed run (docs/distributed.md; null or one rank: this process
  // alone). Rank 0 does the job, and the volumetric targets' embedded simulations are
  // shared among the ranks (jobs/shared_pose_work.h); the other ranks call RunPrepareJob
  // too, and use only `targets` and `num_threads` (they read no file: the model comes
  // from rank 0).
  const Communicator* communicator = nullptr;
  // Memory limit (bytes): the lattice (before meshing) and the simulation (before the
  // volumetric targets) are estimated, and the job stops with exit status 1 and the
  // estimate if either is above it (util/memory_limit.h).
  double max_memory_bytes = kDefaultMaxMemoryBytes;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Runs the job, logging progress to `log`. It holds the output model's writers' lock
// (model/model_directory.h) from the start, and checks before any work that `output`
// may be replaced. Returns false with *error on bad input (invalid options, unreadable
// files, poses with another vertex count, a surface that encloses nothing, no fixed
// vertices, an empty pose set, an output that is not a model without overwrite, a
// model in use by another process, a lattice or simulation whose memory estimate is
// above max_memory_bytes, ...): *status (may be null) is then kBadInput and nothing is
// written. If the embedded simulation of some poses does not converge, the model is
// still written (their targets from the states the solves ended in, for inspection)
// and the job returns false with *status kNotConverged and *error naming the poses.
// The model records its targets' key (ActiveModel::target_key) when all converged.
bool RunPrepareJob(const PrepareJobOptions& options, std::ostream& log, std::string* error,
                   JobStatus* status = nullptr);

}  // namespace aqs

#endif  // AQS_JOBS_PREPARE_JOB_H_
