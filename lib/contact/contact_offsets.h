#ifndef AQS_CONTACT_CONTACT_OFFSETS_H_
#define AQS_CONTACT_CONTACT_OFFSETS_H_

#include <map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "contact/self_contact_pair.h"

namespace aqs {

// What the augmented-Lagrangian update of self-contact pairs (SelfContactPair::offset)
// reads besides the pair and the state.
struct ContactOffsetRule {
  double thickness = 0.0;  // the distance pairs keep
  // No update for a pair deeper than this (s <= -max_depth: its side is in doubt) ...
  double max_depth = 0.0;
  // ... or whose closest points lie farther outside its feature than this
  // (SelfContactDistance's *outside).
  double max_outside = 0.0;
  double max_offset = 0.0;  // offsets stay in [0, max_offset]
};

// The offsets ContactSolver's detection/solve rounds hand on to the next round and path
// step: one per surface vertex for point-triangle pairs (the point's, whichever triangle
// it meets next), one per edge-edge pair, keyed by its two edges (a key of the first edge
// alone let a partner apart clamp a pressed pair's offset to 0).
class ContactOffsets {
 public:
  // All offsets 0, for surface vertices 0 .. num_surface_vertices - 1.
  explicit ContactOffsets(int num_surface_vertices = 0);

  // The offset `pair` starts a round with: its surface vertex's (point-triangle; in
  // range: CHECK) or its edges' (edge-edge; 0 for a pair not updated before).
  double Of(const SelfContactPair& pair) const;

  // After a round's solve at state x (3 x num_vertices, the stencils' indices in range):
  // the pair's offset becomes clamp(offset + thickness - s, 0, max_offset), s its signed
  // distance at x (SelfContactDistance). Unchanged where s is undefined, s <= -max_depth,
  // the closest points lie more than max_outside outside the feature, or the pair is
  // faded out entirely (its fade variable at or below its band's zero: its distance is
  // ill-conditioned there, and a point's offset waits for its next pair). Returns
  // false where it left the offset alone for one of these reasons.
  bool Update(const SelfContactPair& pair, const Eigen::Matrix3Xd& x,
              const ContactOffsetRule& rule);

 private:
  std::vector<double> vertex_;
  std::map<std::pair<int, int>, double> edge_;
};

}  // namespace aqs

#endif  // AQS_CONTACT_CONTACT_OFFSETS_H_
