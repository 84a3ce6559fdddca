#include "util/vertex_ranges.h"

#include <algorithm>
#include <array>
#include <cstdint>

#include "util/line_reader.h"
#include "util/text_split.h"

namespace aqs {

bool ParseVertexRanges(const std::string& text, std::vector<int>* vertices, std::string* error) {
  std::vector<int> out;
  const std::vector<std::string> items = SplitList(text);
  // Each item's vertices [a, b) and its index among the items.
  std::vector<std::array<int, 3>> intervals;
  for (const std::string& item : items) {
    const size_t colon = item.find(':'), dash = item.find('-');
    int a = 0, b = 0;
    if (colon != std::string::npos) {
      if (!ParseInt(item.substr(0, colon), &a) || !ParseInt(item.substr(colon + 1), &b) || b <= a) {
        *error = "vertex range '" + item + "': expected a:b with a < b (a:a is empty)";
        return false;
      }
    } else if (dash != std::string::npos && dash > 0) {
      if (!ParseInt(item.substr(0, dash), &a) || !ParseInt(item.substr(dash + 1), &b) || b < a) {
        *error = "vertex range '" + item + "': expected a-b with a <= b";
        return false;
      }
      b = b < kMaxVertexIndex ? b + 1 : kMaxVertexIndex + 1;  // b included
    } else {
      if (!ParseInt(item, &a)) {
        *error = "vertex range '" + item + "': not an index";
        return false;
      }
      b = a < kMaxVertexIndex ? a + 1 : kMaxVertexIndex + 1;
    }
    if (a < 0) {
      *error = "vertex range '" + item + "': negative index";
      return false;
    }
    // Before any allocation: an index or a count no mesh has (and b = a + 1 must not
    // overflow).
    if (a >= kMaxVertexIndex || b > kMaxVertexIndex ||
        static_cast<long long>(out.size()) + (b - a) > kMaxVertexIndex) {
      *error = "vertex range '" + item + "': beyond " + std::to_string(kMaxVertexIndex) +
               " vertices, more than any mesh has";
      return false;
    }
    for (int v = a; v < b; ++v) out.push_back(v);
    intervals.push_back({a, b, static_cast<int>(intervals.size())});
  }
  // A vertex listed twice would count twice in every mean over the list. The items'
  // intervals by their first vertex: the first that starts before the end of one before
  // it shares its first vertex with that one, the smallest vertex listed twice.
  std::sort(intervals.begin(), intervals.end());
  for (size_t k = 1, reach = 0; k < intervals.size(); ++k) {
    if (intervals[k][0] >= intervals[reach][1]) {
      if (intervals[k][1] > intervals[reach][1]) reach = k;
      continue;
    }
    const int first = std::min(intervals[reach][2], intervals[k][2]);
    const int second = std::max(intervals[reach][2], intervals[k][2]);
    *error = "vertex ranges '" + text + "': vertex " + std::to_string(intervals[k][0]) +
             " is listed twice ('" + items[first] + "' and '" + items[second] + "')";
    return false;
  }
  if (out.empty() && !text.empty()) {
    // "" is the empty set (callers read it as "not given"); "," is a mistake.
    *error = "vertex ranges '" + text + "': no vertex listed";
    return false;
  }
  *vertices = out;
  return true;
}

std::string FormatVertexRanges(const std::vector<int>& vertices) {
  std::string text;
  for (size_t i = 0; i < vertices.size();) {
    size_t j = i + 1;
    while (j < vertices.size() && vertices[j] == vertices[j - 1] + 1) ++j;
    if (!text.empty()) text += ",";
    text += std::to_string(vertices[i]) + ":" + std::to_string(vertices[j - 1] + 1);
    i = j;
  }
  return text;
}

}  // namespace aqs
