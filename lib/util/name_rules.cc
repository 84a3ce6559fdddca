#include "util/name_rules.h"

namespace aqs {

std::string NameProblem(const std::string& name) {
  if (name.empty()) return "is empty";
  const size_t at = name.find_first_of(kNameForbiddenCharacters);
  if (at == std::string::npos) return "";
  const char c = name[at];
  std::string what;
  if (c == '#') {
    what = "'#' (the model files' comment mark)";
  } else if (c == ',') {
    what = "',' (the CSV files' separator)";
  } else {
    what = "white space";
  }
  return "contains " + what + ": names must be one word without '#' or ','";
}

}  // namespace aqs
