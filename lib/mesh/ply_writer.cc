// PLY writing (ASCII, with a per-vertex scalar) and the scalar's colour map (ply_io.h).

#include <glog/logging.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mesh/ply_io.h"
#include "mesh/text_io_util.h"
#include "util/atomic_file.h"
#include "util/number_format.h"
#include "util/finite_values.h"

namespace aqs {
namespace {

// matplotlib's viridis at t = k/8, k = 0..8 (the 9-colour viridis palette).
constexpr std::uint8_t kViridis[9][3] = {
    {68, 1, 84},    {71, 45, 123},  {59, 82, 139},  {44, 114, 142}, {33, 144, 140},
    {39, 173, 129}, {93, 200, 99},  {170, 220, 50}, {253, 231, 37}};

}  // namespace

double PercentileColorMax(std::vector<double> values) {
  if (values.empty()) return 1e-12;
  const auto at = values.begin() + values.size() * 95 / 100;
  std::nth_element(values.begin(), at, values.end());
  return std::max(1e-12, *at);
}

double ErrorMapScale(std::vector<double> values) {
  if (values.empty()) return 1.0;
  std::sort(values.begin(), values.end());
  const double position = (values.size() - 1) * 0.98;
  const size_t low = static_cast<size_t>(std::floor(position));
  const size_t high = std::min(low + 1, values.size() - 1);
  const double top = values[low] + (values[high] - values[low]) * (position - low);
  return top > 0 ? top : 1.0;
}

std::array<std::uint8_t, 3> ScalarColor(double value, double color_max) {
  CHECK_GT(color_max, 0.0) << "color_max must be positive";
  double t = value / color_max;
  if (!(t > 0.0)) t = 0.0;  // also NaN
  if (t > 1.0) t = 1.0;
  const double scaled = 8.0 * t;
  const int k = std::min(7, static_cast<int>(scaled));
  const double f = scaled - k;
  std::array<std::uint8_t, 3> rgb;
  for (int c = 0; c < 3; ++c) {
    const double channel = (1.0 - f) * kViridis[k][c] + f * kViridis[k + 1][c];
    rgb[c] = static_cast<std::uint8_t>(std::lround(channel));
  }
  return rgb;
}

bool WritePlyWithScalar(const std::string& path, const SurfaceMesh& surface,
                        const std::vector<double>& values, double color_max, std::string* error) {
  const int num_vertices = surface.num_vertices();
  CHECK_EQ(values.size(), static_cast<size_t>(num_vertices)) << "one value per vertex";
  CHECK_GT(color_max, 0.0) << "color_max must be positive";
  if (!AllFiniteForWriting(path, surface.vertices, "vertex", error)) return false;
  for (int v = 0; v < num_vertices; ++v) {
    if (!std::isfinite(values[v])) {
      *error = path + ": the value of vertex " + std::to_string(v) + " is not finite (" +
               FormatDouble(values[v]) + ")";
      return false;
    }
  }
  auto check_index = [num_vertices](int v) {
    CHECK(v >= 0 && v < num_vertices)
        << "surface index " << v << " out of range [0, " << num_vertices << ")";
  };
  const bool polygons = !surface.face_offsets.empty();
  int max_corners = 3;
  if (polygons) {
    CHECK_EQ(surface.face_offsets.front(), 0);
    CHECK_EQ(static_cast<size_t>(surface.face_offsets.back()), surface.face_vertices.size());
    for (int p = 0; p < surface.num_polygons(); ++p) {
      const int corners = surface.face_offsets[p + 1] - surface.face_offsets[p];
      CHECK_GE(corners, 3) << "polygon " << p << " has fewer than 3 vertices";
      max_corners = std::max(max_corners, corners);
    }
  }
  AtomicFileWriter writer(path);
  {
    mesh_internal::ChunkedWriter out(&writer.stream());
    std::string* buffer = out.buffer();
    *buffer += "ply\nformat ascii 1.0\ncomment written by ActiveQS\n";
    *buffer += "comment red green blue: viridis of value / color_max clamped to [0, 1], color_max ";
    AppendDouble(color_max, buffer);
    *buffer += "\nelement vertex ";
    mesh_internal::AppendInt(num_vertices, buffer);
    *buffer +=
        "\nproperty double x\nproperty double y\nproperty double z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        "property double value\nelement face ";
    mesh_internal::AppendInt(surface.num_polygons(), buffer);
    *buffer += max_corners > 255 ? "\nproperty list int int vertex_indices\n"
                                 : "\nproperty list uchar int vertex_indices\n";
    *buffer += "end_header\n";
    for (int v = 0; v < num_vertices; ++v) {
      for (int i = 0; i < 3; ++i) {
        AppendDouble(surface.vertices(i, v), buffer);
        buffer->push_back(' ');
      }
      for (std::uint8_t channel : ScalarColor(values[v], color_max)) {
        mesh_internal::AppendInt(channel, buffer);
        buffer->push_back(' ');
      }
      AppendDouble(values[v], buffer);
      buffer->push_back('\n');
      out.MaybeFlush();
    }
    if (polygons) {
      for (int p = 0; p < surface.num_polygons(); ++p) {
        mesh_internal::AppendInt(surface.face_offsets[p + 1] - surface.face_offsets[p], buffer);
        for (int i = surface.face_offsets[p]; i < surface.face_offsets[p + 1]; ++i) {
          check_index(surface.face_vertices[i]);
          buffer->push_back(' ');
          mesh_internal::AppendInt(surface.face_vertices[i], buffer);
        }
        buffer->push_back('\n');
        out.MaybeFlush();
      }
    } else {
      for (int t = 0; t < surface.num_triangles(); ++t) {
        *buffer += "3";
        for (int i = 0; i < 3; ++i) {
          check_index(surface.triangles(i, t));
          buffer->push_back(' ');
          mesh_internal::AppendInt(surface.triangles(i, t), buffer);
        }
        buffer->push_back('\n');
        out.MaybeFlush();
      }
    }
  }
  return writer.Commit(error);
}

}  // namespace aqs
