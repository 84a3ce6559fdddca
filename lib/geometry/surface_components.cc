#include "geometry/surface_components.h"

#include <glog/logging.h>

#include <algorithm>
#include <array>
#include <utility>

#include "util/disjoint_sets.h"

namespace aqs {
namespace {

// Vertex-to-edge incidence in compressed form: the edges of vertex v are
// edges[offsets[v] .. offsets[v + 1]), in increasing edge order.
struct Incidence {
  std::vector<int> offsets;
  std::vector<int> edges;
  std::vector<int> cursor;  // first entry not yet known to be used

  Incidence(int num_vertices, const std::vector<int>& key) : offsets(num_vertices + 1, 0) {
    for (int v : key) ++offsets[v + 1];
    for (int v = 0; v < num_vertices; ++v) offsets[v + 1] += offsets[v];
    edges.resize(key.size());
    cursor.assign(offsets.begin(), offsets.end() - 1);
    for (int e = 0; e < static_cast<int>(key.size()); ++e) edges[cursor[key[e]]++] = e;
    cursor.assign(offsets.begin(), offsets.end() - 1);
  }

  // The first unused edge at v, or -1.
  int NextUnused(int v, const std::vector<char>& used) {
    while (cursor[v] < offsets[v + 1] && used[edges[cursor[v]]]) ++cursor[v];
    return cursor[v] < offsets[v + 1] ? edges[cursor[v]] : -1;
  }
};

}  // namespace

SurfaceComponents FindSurfaceComponents(int num_vertices, const Eigen::Matrix3Xi& triangles) {
  CHECK_GE(num_vertices, 0);
  const int num_triangles = static_cast<int>(triangles.cols());
  DisjointSets sets(num_vertices);
  std::vector<char> used(num_vertices, 0);
  for (int t = 0; t < num_triangles; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int v = triangles(k, t);
      CHECK(v >= 0 && v < num_vertices) << "triangle " << t << " has vertex index " << v
                                        << " out of range [0, " << num_vertices << ")";
      used[v] = 1;
    }
    sets.Union(triangles(0, t), triangles(1, t));
    sets.Union(triangles(0, t), triangles(2, t));
  }
  SurfaceComponents components;
  components.vertex_component.assign(num_vertices, -1);
  std::vector<int> root_label(num_vertices, -1);
  for (int v = 0; v < num_vertices; ++v) {
    if (!used[v]) continue;
    const int root = sets.Find(v);
    if (root_label[root] < 0) {
      root_label[root] = components.num_components();
      components.vertices.emplace_back();
    }
    components.vertex_component[v] = root_label[root];
    components.vertices[root_label[root]].push_back(v);
  }
  components.triangle_component.resize(num_triangles);
  for (int t = 0; t < num_triangles; ++t) {
    components.triangle_component[t] = components.vertex_component[triangles(0, t)];
  }
  return components;
}

std::vector<BoundaryLoop> FindBoundaryLoops(const Eigen::Matrix3Xi& triangles) {
  const int num_triangles = static_cast<int>(triangles.cols());
  int num_vertices = 0;
  // Directed edges in triangle order: (smallest vertex, largest vertex, position).
  std::vector<std::array<int, 3>> keyed;
  keyed.reserve(static_cast<size_t>(num_triangles) * 3);
  for (int t = 0; t < num_triangles; ++t) {
    // A degenerate triangle (a repeated vertex) adds no edge: its (a, b) and (b, a) would
    // make a real boundary edge a-b look shared.
    const bool degenerate = triangles(0, t) == triangles(1, t) ||
                            triangles(1, t) == triangles(2, t) ||
                            triangles(0, t) == triangles(2, t);
    for (int k = 0; k < 3; ++k) {
      const int a = triangles(k, t), b = triangles((k + 1) % 3, t);
      CHECK(a >= 0) << "triangle " << t << " has negative vertex index " << a;
      num_vertices = std::max(num_vertices, a + 1);
      if (degenerate) continue;
      keyed.push_back({std::min(a, b), std::max(a, b), 3 * t + k});
    }
  }
  std::sort(keyed.begin(), keyed.end());

  // Boundary edges (undirected edges used once), in triangle order, directed as in
  // their triangle.
  std::vector<int> positions;
  for (size_t begin = 0; begin < keyed.size();) {
    size_t end = begin + 1;
    while (end < keyed.size() && keyed[end][0] == keyed[begin][0] &&
           keyed[end][1] == keyed[begin][1]) {
      ++end;
    }
    if (end - begin == 1) positions.push_back(keyed[begin][2]);
    begin = end;
  }
  std::sort(positions.begin(), positions.end());
  const int num_edges = static_cast<int>(positions.size());
  std::vector<int> from(num_edges), to(num_edges);
  for (int e = 0; e < num_edges; ++e) {
    const int t = positions[e] / 3, k = positions[e] % 3;
    from[e] = triangles(k, t);
    to[e] = triangles((k + 1) % 3, t);
  }
  Incidence outgoing(num_vertices, from);
  Incidence incoming(num_vertices, to);
  std::vector<char> used(num_edges, 0);

  // The next vertex after v along an unused edge, forward (v -> w) if possible, else
  // backward (w -> v, against its orientation); -1 if v has no unused edge.
  auto step = [&](int v, Incidence* preferred, Incidence* other,
                  const std::vector<int>& preferred_end, const std::vector<int>& other_end) {
    int e = preferred->NextUnused(v, used);
    if (e >= 0) {
      used[e] = 1;
      return preferred_end[e];
    }
    e = other->NextUnused(v, used);
    if (e >= 0) {
      used[e] = 1;
      return other_end[e];
    }
    return -1;
  };

  std::vector<BoundaryLoop> loops;
  for (int first = 0; first < num_edges; ++first) {
    if (used[first]) continue;
    used[first] = 1;
    BoundaryLoop loop;
    const int start = from[first];
    loop.vertices.push_back(start);
    int current = to[first];
    while (current != start && current >= 0) {
      loop.vertices.push_back(current);
      current = step(current, &outgoing, &incoming, to, from);
    }
    if (current < 0) {
      // An open chain: extend it backwards from its start as far as it goes.
      loop.closed = false;
      std::vector<int> before;
      for (int v = step(start, &incoming, &outgoing, from, to); v >= 0;
           v = step(v, &incoming, &outgoing, from, to)) {
        before.push_back(v);
      }
      loop.vertices.insert(loop.vertices.begin(), before.rbegin(), before.rend());
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

}  // namespace aqs
