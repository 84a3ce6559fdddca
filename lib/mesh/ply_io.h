#ifndef AQS_MESH_PLY_IO_H_
#define AQS_MESH_PLY_IO_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mesh/surface_mesh.h"

namespace aqs {

// The colour of a scalar in WritePlyWithScalar: t = value / color_max clamped to
// [0, 1] (NaN counts as 0) through viridis (matplotlib's perceptually uniform map, dark
// purple (68, 1, 84) at 0, teal (33, 144, 140) at 0.5, yellow (253, 231, 37) at 1),
// piecewise linear in sRGB between its 9 colours at t = k/8, rounded to 8 bits. Returns
// red, green, blue. CHECKs color_max > 0.
std::array<std::uint8_t, 3> ScalarColor(double value, double color_max);

// The colour_max of an error or uncertainty map: the 95th percentile of `values` (the
// element at index size * 95 / 100 in sorted order), so that a few large values do not
// wash out the rest; at least 1e-12 (and 1e-12 for no values).
double PercentileColorMax(std::vector<double> values);

// The colour_max of the evaluation's error maps, the PLY fields and the report's pictures
// (scripts/evaluation_report.py, percentile_scale) alike: the 98th percentile of `values`
// (a pose's methods' errors over the measured vertices) as numpy computes it by default
// (sorted v, position (n - 1) 0.98, linear between its two neighbours); 1 for no values
// or a percentile <= 0.
double ErrorMapScale(std::vector<double> values);

// Writes `surface` as an ASCII PLY (format ascii 1.0) with one scalar per vertex, for
// viewing an error map in ParaView, MeshLab or Blender:
//
//   element vertex N: property double x, y, z; property uchar red, green, blue
//                     (ScalarColor(value, color_max)); property double value;
//   element face F:   property list uchar int vertex_indices (list int int when a
//                     polygon has more than 255 corners): the surface's polygons, or
//                     its triangles when it has none (0-based, as PLY wants).
//
// A comment line records color_max. Numbers read back bit for bit (AppendDouble);
// the file is written atomically. values must have one entry per vertex and color_max
// must be positive (CHECK). Returns false with *error if a value or a coordinate is not
// finite (naming the file and the vertex; nothing is written) or the file cannot be
// written.
bool WritePlyWithScalar(const std::string& path, const SurfaceMesh& surface,
                        const std::vector<double>& values, double color_max, std::string* error);

// Reads the points of a scan (3 x count into *points), choosing the reader by the
// file's extension (case-insensitive):
//
//   .obj  the 'v' records, through ReadObj (faces are checked by it but not used);
//   .ply  PLY in any of its three formats (ascii 1.0, binary_little_endian 1.0,
//         binary_big_endian 1.0): the element "vertex" and its properties x, y and z,
//         which may have any numeric PLY type (char uchar short ushort int uint float
//         double, or int8 uint8 int16 uint16 int32 uint32 float32 float64). Other
//         properties of the vertex element (normals, colours, ...), including list
//         properties, and all other elements (faces, edges, ...) are read and not used:
//         for a list property, its count (of the declared count type) says how many
//         items follow. In ASCII files every value is parsed as its declared type,
//         used or not (an integer in the type's range; for float and double a decimal
//         number, or nan, inf, -inf, which scanners write for missing normals; never
//         hexadecimal), so a damaged file is reported wherever the damage is; x, y and z
//         must be finite decimal numbers. Binary values are taken as they are, except
//         that x, y and z must be finite. 'comment' and 'obj_info' header lines are ignored. The
//         whole file is read: a file truncated anywhere is reported, and so is data
//         after the header's last element (counts smaller than the data would
//         otherwise drop points without a word). In ASCII files each element instance
//         is one line (blank lines are skipped); lines are at most kMaxLineBytes long.
//         Only regular files are read (util/input_file.h).
//
// Other extensions are an error listing both. Errors name the file and, for the header
// and ASCII data, the 1-based line ("scan.ply:12: ..."): not a PLY file (the first line
// must be "ply"), an unknown format, an unsupported property type, no vertex element,
// no x, y or z property (or one that is a list), a missing end_header, truncated data
// ("truncated: the file ends in element 'vertex' ..."), wrong value counts, non-numbers.
// A point with a NaN or infinite coordinate and a file without points are errors too.
// On failure *points is unchanged.
bool ReadPointCloud(const std::string& path, Eigen::Matrix3Xd* points, std::string* error);

}  // namespace aqs

#endif  // AQS_MESH_PLY_IO_H_
