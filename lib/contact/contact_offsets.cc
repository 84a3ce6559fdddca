#include "contact/contact_offsets.h"

#include <algorithm>

#include <glog/logging.h>

namespace aqs {

ContactOffsets::ContactOffsets(int num_surface_vertices) : vertex_(num_surface_vertices, 0.0) {}

double ContactOffsets::Of(const SelfContactPair& pair) const {
  if (pair.kind == SelfContactPair::Kind::kEdgeEdge) {
    const auto found = edge_.find({pair.edge, pair.second_edge});
    return found != edge_.end() ? found->second : 0.0;
  }
  CHECK(pair.surface_vertex >= 0 && pair.surface_vertex < static_cast<int>(vertex_.size()));
  return vertex_[pair.surface_vertex];
}

bool ContactOffsets::Update(const SelfContactPair& pair, const Eigen::Matrix3Xd& x,
                            const ContactOffsetRule& rule) {
  const Eigen::Vector3d points[4] = {pair.point.Position(x), pair.corner[0].Position(x),
                                     pair.corner[1].Position(x), pair.corner[2].Position(x)};
  double s = 0, outside = 0, fade = 0;
  if (!SelfContactDistance(pair, points, &s, nullptr, &outside) ||
      !(outside <= rule.max_outside) || !(s > -rule.max_depth) ||
      !SelfContactFadeVariable(pair, points, &fade, nullptr) || !(fade > FadeBandOf(pair).zero)) {
    return false;
  }
  double* offset;
  if (pair.kind == SelfContactPair::Kind::kEdgeEdge) {
    offset = &edge_[{pair.edge, pair.second_edge}];
  } else {
    CHECK(pair.surface_vertex >= 0 && pair.surface_vertex < static_cast<int>(vertex_.size()));
    offset = &vertex_[pair.surface_vertex];
  }
  *offset = std::clamp(*offset + rule.thickness - s, 0.0, rule.max_offset);
  return true;
}

}  // namespace aqs
