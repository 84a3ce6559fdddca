#ifndef AQS_PREPARE_VOLUMETRIC_TARGETS_H_
#define AQS_PREPARE_VOLUMETRIC_TARGETS_H_

#include <ostream>
#include <string>

#include "equilibrium/quasistatic_solver.h"
#include "mesh/mesh_measures.h"
#include "model/active_model.h"

namespace aqs {

struct VolumetricTargetOptions {
  // Spring stiffness per unit surface area, relative to the material: surface vertex i
  // gets k_i = relative_stiffness * mean(mu) * A_i / h, with A_i its share of the
  // neutral surface's area and h the mean edge length of the simulation mesh (so that
  // 1 means springs as stiff as one layer of elements).
  double relative_stiffness = 100.0;
  QuasistaticSolverOptions solver;
  // Poses solved in parallel (each with its own solver).
  int num_threads = 2;
  // A pose whose direct solve fails is retried in this many steps, moving the targets
  // and bones from rest to the pose.
  int continuation_steps = 4;
};

// Volumetric targets by embedded simulation. For every training pose p of `model`
// (which needs mesh, mu, fixed vertices, bones, neutral surface, embedding and pose
// surfaces): the passive body (S = I), its fixed vertices at pose p's bone positions,
// is pulled by zero-rest-length springs from its embedded surface points to pose p's
// surface; at that equilibrium x_p, element e's target is the symmetric polar factor
// S = sqrt(F_e^T F_e) of its deformation gradient (so that S reproduces x_p's shape up
// to the rotation the equilibrium chooses). Fills pose.target and the mean and max
// distance between the embedded surface and the pose; writes one line per pose to
// `log`. Returns false with *error if a pose's equilibrium cannot be reached.
bool MakeVolumetricTargets(const VolumetricTargetOptions& options, ActiveModel* model,
                           std::ostream& log, std::string* error);

// The spring stiffness of MakeVolumetricTargets per neutral surface vertex
// (num_surface_vertices): relative_stiffness * mean(mu) * A_i / h (see
// VolumetricTargetOptions); vertices with no area get the mean area.
Eigen::VectorXd AttachmentStiffness(const ActiveModel& model, double relative_stiffness);

// sqrt(F^T F), the symmetric positive semi-definite polar factor of F.
Eigen::Matrix3d SymmetricPolarFactor(const Eigen::Matrix3d& f);


}  // namespace aqs

#endif  // AQS_PREPARE_VOLUMETRIC_TARGETS_H_
