#ifndef AQS_UTIL_VERTEX_RANGES_H_
#define AQS_UTIL_VERTEX_RANGES_H_

// Vertex subsets written as index ranges, as the apps' vertex flags take them
// (aqs_evaluate and aqs_bench_fit --error_vertices, aqs_fit --compare_vertices,
// aqs_collide --contact_vertices) and as the evaluation passes them to its report
// script.

#include <string>
#include <vector>

namespace aqs {

// Parses a comma-separated list of items, each one of
//   "a:b"  vertices a to b-1 (a < b),
//   "a-b"  vertices a to b, both included (a <= b),
//   "a"    vertex a alone,
// with a, b decimal integers >= 0 (ParseInt: no spaces, no trailing characters). Empty
// items are skipped; "" is the empty set (callers read it as "not given", e.g. all
// vertices), but a text that lists no vertex otherwise ("," or "5:5") is an error: it
// would mean "all" by mistake. Output: *vertices, the indices in the order written (no
// sorting, no upper bound: callers check against their vertex count). A vertex listed
// twice (overlapping items) is an error: it would count twice in every mean over the
// list. Returns false with *error naming the item ("vertex range 'x': expected a:b with
// a < b", "... a-b ...", "... not an index", "... negative index", "vertex ranges 'x':
// no vertex listed", "vertex ranges 'x': vertex v is listed twice ('i' and 'j')"), and
// *vertices unchanged.
// Indices and counts are refused from kMaxVertexIndex on ("... beyond N vertices"),
// before anything is allocated.
constexpr int kMaxVertexIndex = 50000000;
bool ParseVertexRanges(const std::string& text, std::vector<int>* vertices, std::string* error);

// The inverse: runs of consecutive indices as "a:b" (a to b-1), comma-separated, in the
// given order (e.g. {0, 1, 2, 5} -> "0:3,5:6"); "" for none.
std::string FormatVertexRanges(const std::vector<int>& vertices);

}  // namespace aqs

#endif  // AQS_UTIL_VERTEX_RANGES_H_
