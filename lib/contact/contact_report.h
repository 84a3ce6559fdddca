#ifndef AQS_CONTACT_CONTACT_REPORT_H_
#define AQS_CONTACT_CONTACT_REPORT_H_

#include <string>
#include <vector>

namespace aqs {

// Intersecting triangle pairs of a surface with itself (ContactSolver's contact
// triangles), by how they relate to the rest surface.
struct SelfIntersectionCounts {
  int all = 0;
  int new_pairs = 0;  // not intersecting at rest
  int separated = 0;  // new, and the triangles farther apart at rest than rest_tolerance
  int clean = 0;      // new, and neither triangle intersects any triangle at rest
  // Separated, and the two triangles are pairs self contact acts on: no corner of one
  // within the exclusion rings of a corner of the other, and their rest normals facing
  // each other (dot <= max_normal_alignment). The other separated pairs are folds of
  // one sheet (e.g. a mouth or eye corner pressed flat), which contact, by design, does
  // not tell apart from the sheet's own smooth bending.
  int facing = 0;
};

// What ContactSolver::Measure finds at one surface state: how far the surface is into
// the obstacles and through itself.
struct ContactMeasurement {
  // Into obstacles: the deepest surface point (0 if none) and how many points are inside.
  double max_penetration = 0.0;
  int penetrating_points = 0;
  // Intersecting triangle pairs of the surface with itself: all; those not intersecting
  // at rest (what contact can undo); of those, the pairs whose triangles were apart at
  // rest by more than rest_tolerance (the rest, touching at rest, such as the ICT lips
  // at the mouth corners, have no well-defined side); and the new pairs whose two
  // triangles intersect nothing at rest (the rest, such as the ICT lips' commissure,
  // already pass through the surface at rest, so contact has no side to keep for them);
  // and the separated pairs that face each other across the exclusion rings (the pairs
  // contact acts on; path steps are halved and rounds go on for these).
  SelfIntersectionCounts self_intersections;
  // Intersecting triangle pairs of the surface with the obstacles.
  int obstacle_intersections = 0;
};

// What ContactSolver::Resolve did.
struct ContactReport {
  ContactMeasurement before;  // at the contact-free start
  ContactMeasurement after;   // at the result
  // Self-intersecting pairs of the neutral (rest) surface, for reference: data such as
  // the ICT face already intersect at the mouth corners, which contact cannot undo (it
  // keeps points on the side they had at rest).
  int self_intersections_rest = 0;
  // How far the resolution moved the surface: all vertices, and those farther than
  // far_distance from every point that was in contact in any round (the rest of the
  // surface).
  double mean_displacement = 0.0, max_displacement = 0.0;
  double far_distance = 0.0, max_far_displacement = 0.0;
  int rounds = 0;        // detection/solve rounds, over all path steps
  int path_steps = 0;    // accepted path steps (0: no path)
  int path_halvings = 0;  // steps halved because they added intersections
  int obstacle_contacts = 0, self_contacts = 0;  // active at the end
  bool converged = true;
  std::vector<std::string> round_summaries;  // each round's candidates and solve
  std::string Summary() const;
  // 'name value' lines (after a '#' comment with the summary and one per round), for
  // scripts: each measurement as NAME_before and NAME_after (max_penetration_before,
  // max_penetration_after, penetrating_points_before, ...; self_intersections_rest after
  // penetrating_points_after), then the displacements, ..., converged (0/1).
  std::string ToText() const;
};

}  // namespace aqs

#endif  // AQS_CONTACT_CONTACT_REPORT_H_
