#ifndef AQS_PREPARE_VOLUMETRIC_TARGETS_H_
#define AQS_PREPARE_VOLUMETRIC_TARGETS_H_

#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "equilibrium/quasistatic_solver.h"
#include "mesh/mesh_measures.h"
#include "model/active_model.h"
#include "physics/actuation.h"

namespace aqs {

class TargetStore;

// The largest VolumetricTargetOptions::relative_stiffness.
inline constexpr double kMaxRelativeStiffness = 1e8;

// The target of an element that a pose's embedded simulation inverts (det F <= 0).
enum class InvertedTargets {
  // S = V diag(sigma) V^T of the rotation-variant SVD F = U diag(sigma) V^T
  // (physics/rotation_variant_svd.h; sigma_2 < 0 where det F < 0): R S = F for the
  // rotation R = U V^T, so the target reproduces the inverted shape exactly and the
  // pose's embedded equilibrium has zero energy under its targets. S has one negative
  // eigenvalue.
  kExact,
  // S = sqrt(F^T F), the element's mirror image: no rotation takes it to F, and the
  // element pushes the pose's equilibrium away from the embedded one.
  kMirror,
};

// "exact", "mirror" (flag values), and back; false for another name.
const char* InvertedTargetsName(InvertedTargets kind);
bool ParseInvertedTargets(const std::string& name, InvertedTargets* kind);

struct VolumetricTargetOptions {
  // Spring stiffness per unit surface area, relative to the material: surface vertex i
  // gets k_i = relative_stiffness * mean(mu) * A_i / h, with A_i its share of the
  // neutral surface's area and h the mean edge length of the simulation mesh (so that
  // 1 means springs as stiff as one layer of elements).
  // At most kMaxRelativeStiffness: far stiffer springs add nothing but round-off (on a
  // small body the targets at 1e4 and 1e9 agree to 3 digits, and above 2e9 the solves
  // end at the energy's round-off floor without converging).
  double relative_stiffness = 100.0;
  QuasistaticSolverOptions solver;
  // Poses solved in parallel (each with its own solver).
  int num_threads = 2;
  // A pose whose direct solve fails is retried in this many steps, moving the targets
  // and bones from rest to the pose.
  int continuation_steps = 4;
  // What inverted elements get as their targets (see InvertedTargets).
  InvertedTargets inverted_targets = InvertedTargets::kExact;
  // Keep every pose's target in this folder as it is made (prepare/target_store.h;
  // empty: none), and take the poses found there for this model and these options
  // instead of solving them again: a stopped prepare resumes.
  std::string store_directory;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Volumetric targets by embedded simulation. For every training pose p of `model`
// (which needs mesh, mu, fixed vertices, bones, neutral surface, embedding and pose
// surfaces): the passive body (S = I), its fixed vertices at pose p's bone positions,
// is pulled by zero-rest-length springs from its embedded surface points to pose p's
// surface; at that equilibrium x_p, element e's target is the symmetric polar factor
// S = sqrt(F_e^T F_e) of its deformation gradient (so that S reproduces x_p's shape up
// to the rotation the equilibrium chooses); an element x_p inverts, det F <= 0, gets
// ElementTarget's target for options.inverted_targets, and the pose line counts them. Fills
// pose.target and the mean and max distance between the embedded surface and the pose;
// writes one line per pose to `log` (with the count of inverted elements, if any).
// Returns false with *error if a pose's equilibrium cannot be reached, unless
// `unconverged` is given: then such a pose's target is made from the state its solve
// ended in (if that is finite; else the pose gets no target, errors 0 and a line that
// says so), the pose's message is
// appended to *unconverged, and the function returns true. Returns false for invalid
// options (options.Validate) either way.
bool MakeVolumetricTargets(const VolumetricTargetOptions& options, ActiveModel* model,
                           std::ostream& log, std::string* error,
                           std::vector<std::string>* unconverged = nullptr);

// MakeVolumetricTargets for the poses `poses` of `model` alone (each pose's target and
// embedding errors; the other poses are untouched), none taken from a store:
// (*failures)[p] (num_poses entries) becomes pose p's message if its solve did not
// converge (its target then from the state the solve ended in, or empty (6 x 0) if that
// is not finite), else "". With `store` (may be null), each pose is kept there as it is
// made (a failure to keep it is a warning in `log`). options.store_directory is not
// used. For poses shared among processes (jobs/shared_pose_work.h); the caller has
// validated the options (options.Validate).
void MakeVolumetricTargetsOf(const VolumetricTargetOptions& options,
                             const std::vector<int>& poses, const TargetStore* store,
                             ActiveModel* model, std::ostream& log,
                             std::vector<std::string>* failures);

// MakeVolumetricTargetsOf over several calls: keeps its solvers (one per thread, each
// with the rest stiffness factor every pose's solve starts from) from one call to the
// next, so that poses made a few at a time (the rounds of jobs/shared_pose_work.h, each
// kept before the next) factorize the rest stiffness once per thread, not once per
// call. Each pose's target is the same as MakeVolumetricTargetsOf's, whichever call
// makes it.
class VolumetricTargetMaker {
 public:
  // For `model`'s mesh, material, embedding, neutral surface and bones, which must not
  // change while the maker lives (Make writes the poses' targets and errors only).
  // options must be valid (options.Validate); store_directory is not used.
  VolumetricTargetMaker(const VolumetricTargetOptions& options, const ActiveModel& model);
  ~VolumetricTargetMaker();
  VolumetricTargetMaker(const VolumetricTargetMaker&) = delete;
  VolumetricTargetMaker& operator=(const VolumetricTargetMaker&) = delete;

  // MakeVolumetricTargetsOf(options, poses, store, model, log, failures) for the model
  // given to the constructor.
  void Make(const std::vector<int>& poses, const TargetStore* store, ActiveModel* model,
            std::ostream& log, std::vector<std::string>* failures);

 private:
  struct Worker;
  const VolumetricTargetOptions options_;
  const ActiveModel& model_;
  std::unique_ptr<ShapeTargetModel> physics_;
  Eigen::VectorXd stiffness_;  // SurfaceSpringStiffness (model/surface_springs.h)
  std::vector<std::unique_ptr<Worker>> workers_;  // made when first needed
};

// The memory of the equilibrium solves of a mesh of num_elements elements (bytes): one
// solver with its stiffness factorization, about 8 kB per element at 250,000 elements
// (docs/benchmarks.md: 2.0 GB peak), growing as the cube root of the element count
// above that (the factor's fill).
double EquilibriumSolverMemoryBytes(double num_elements);

// sqrt(F^T F), the symmetric positive semi-definite polar factor of F.
Eigen::Matrix3d SymmetricPolarFactor(const Eigen::Matrix3d& f);

// V diag(sigma) V^T of the rotation-variant SVD F = U diag(sigma) V^T: the symmetric S
// with (U V^T) S = F, a proper rotation times S, for any F. Equals SymmetricPolarFactor
// where det F > 0; has one negative eigenvalue where det F < 0.
Eigen::Matrix3d SignedSymmetricFactor(const Eigen::Matrix3d& f);

// Element target (six numbers, physics/actuation.h) of the deformation gradient f:
// SymmetricPolarFactor where det f > 0; where det f <= 0, SignedSymmetricFactor for
// kExact, SymmetricPolarFactor for kMirror.
Vector6d ElementTarget(const Eigen::Matrix3d& f, InvertedTargets inverted_targets);

}  // namespace aqs

#endif  // AQS_PREPARE_VOLUMETRIC_TARGETS_H_
