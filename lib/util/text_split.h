#ifndef AQS_UTIL_TEXT_SPLIT_H_
#define AQS_UTIL_TEXT_SPLIT_H_

// The list splitters (and a joiner, and a line flattener) of flags and small text
// fields (the whitespace token splitter of file lines is SplitTokens,
// util/line_reader.h).

#include <string>
#include <vector>

namespace aqs {

// The non-empty items of a `separator`-separated list: "a,b,,c" -> {"a", "b", "c"};
// "" and ",," -> {}. Items are not trimmed. For flags that list names, paths or ranges.
std::vector<std::string> SplitList(const std::string& text, char separator = ',');

// Every field of a `separator`-separated line, empty ones included: "a,,b" ->
// {"a", "", "b"}, ",a" -> {"", "a"}. As std::getline reads them: a trailing separator
// does not start another (empty) field ("a," -> {"a"}), and "" has no fields. For CSV
// rows and number lists, where an empty field is an error the caller reports.
std::vector<std::string> SplitFields(const std::string& text, char separator = ',');

// The inverse for integers: {64, 64} -> "64,64"; {} -> `empty` (e.g. "none" for a
// network without hidden layers).
std::string JoinInts(const std::vector<int>& values, const std::string& empty = "");

// `text` with every line break (\n, \r) replaced by a space: a message kept as one line
// of a record file.
std::string OneLine(std::string text);

}  // namespace aqs

#endif  // AQS_UTIL_TEXT_SPLIT_H_
