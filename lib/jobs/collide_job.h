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

CollideJobResult RunCollideJob(const CollideJobOptions& options, std::ostream& log);

}  // namespace aqs

#endif  // AQS_JOBS_COLLIDE_JOB_H_
