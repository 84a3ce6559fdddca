#include "util/text_split.h"

#include <utility>

namespace aqs {

std::vector<std::string> SplitFields(const std::string& text, char separator) {
  std::vector<std::string> fields;
  size_t begin = 0;
  while (begin < text.size()) {
    size_t end = text.find(separator, begin);
    if (end == std::string::npos) end = text.size();
    fields.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  return fields;
}

std::vector<std::string> SplitList(const std::string& text, char separator) {
  std::vector<std::string> items;
  for (std::string& field : SplitFields(text, separator)) {
    if (!field.empty()) items.push_back(std::move(field));
  }
  return items;
}

std::string JoinInts(const std::vector<int>& values, const std::string& empty) {
  if (values.empty()) return empty;
  std::string text;
  for (size_t i = 0; i < values.size(); ++i) text += (i > 0 ? "," : "") + std::to_string(values[i]);
  return text;
}

std::string OneLine(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

}  // namespace aqs
