#ifndef AQS_JOBS_COLLIDE_JOB_H_
#define AQS_JOBS_COLLIDE_JOB_H_

#include <ostream>
#include <string>

#include "contact/contact_solver.h"
#include "jobs/simulate_job.h"

namespace aqs {

// What aqs_collide does: a trained model's pose (a latent, or a training pose), then
// the same equilibrium with contact against rigid obstacles and itself.
struct CollideJobOptions {
  std::string model;      // trained model directory; required
  std::string latent;     // a latent file, or
  std::string pose;       // a training pose's name (its latent and bone motion)
  // Obstacles: "path [vertices=a:b] [bone=name]" items separated by commas; an
  // obstacle with a bone moves with that bone's transform of the pose.
  std::string obstacles;
  std::string output;          // the surface with contact (OBJ); required
  std::string output_before;   // optional: the surface without contact (OBJ)
  std::string output_volume;   // optional: the equilibrium with contact (.vtu/.mesh)
  std::string report;          // optional: the report as text
  // Optional: PLY of the surface with contact and, per vertex, the count of
  // self-intersecting triangle pairs (not intersecting at rest) it is part of.
  std::string output_intersections;
  ContactOptions contact;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

struct CollideJobResult {
  JobStatus status = JobStatus::kOk;
  std::string message;
  ContactReport report;
};

// Runs aqs_collide: loads the trained model, decodes the pose (options.latent or
// options.pose: its latent and bone motions), solves its equilibrium without contact,
// then resolves contact against the obstacles (moved by their bones' transforms of the
// pose) and the surface itself (ContactSolver::Resolve), and writes the outputs that are
// set (surfaces as OBJ in the neutral's vertex order, the volume by extension, the
// intersection counts as PLY, the report as text; each atomically) and logs to `log`.
// Status: kOk; kBadInput for invalid options, unreadable or mismatched inputs, or an
// output that cannot be written (nothing written); kNotConverged if the equilibrium
// without contact is not reached (its finite surface still goes to output_before, for
// inspection), if the contact solve fails (nothing written), or if the equilibrium with
// contact misses its tolerance (the outputs are written). `message` says why.
CollideJobResult RunCollideJob(const CollideJobOptions& options, std::ostream& log);

}  // namespace aqs

#endif  // AQS_JOBS_COLLIDE_JOB_H_
