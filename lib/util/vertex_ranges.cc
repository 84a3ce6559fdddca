#include "util/vertex_ranges.h"

#include <algorithm>
#include <cstdint>
#include <utility>

#include "util/line_reader.h"
#include "util/text_split.h"

namespace aqs {

bool ParseVertexRanges(const std::string& text, std::vector<int>* vertices, std::string* error) {
  std::vector<int> out;
  const std::vector<std::string> items = SplitList(text);
  std::vector<size_t> item_ends;  // out's size after each item
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
    item_ends.push_back(out.size());
  }
  // A vertex listed twice would count twice in every mean over the list.
  std::vector<std::pair<int, size_t>> sorted(out.size());  // (vertex, position in out)
  for (size_t k = 0; k < out.size(); ++k) sorted[k] = {out[k], k};
  std::sort(sorted.begin(), sorted.end());
  for (size_t k = 1; k < sorted.size(); ++k) {
    if (sorted[k].first != sorted[k - 1].first) continue;
    auto item_of = [&](size_t position) {
      return items[std::upper_bound(item_ends.begin(), item_ends.end(), position) -
                   item_ends.begin()];
    };
    *error = "vertex ranges '" + text + "': vertex " + std::to_string(sorted[k].first) +
             " is listed twice ('" + item_of(sorted[k - 1].second) + "' and '" +
             item_of(sorted[k].second) + "')";
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
