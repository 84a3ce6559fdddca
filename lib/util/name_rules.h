#ifndef AQS_UTIL_NAME_RULES_H_
#define AQS_UTIL_NAME_RULES_H_

#include <string>

namespace aqs {

// Names the project writes as one field of its text files (pose, bone and frame names in
// the model's poses.txt and bones.txt, in evaluation.csv and frames.csv) must not contain
// these characters: white space (the model files' separator), '#' (their comment mark,
// which would cut the line) and ',' (the CSV separator).
inline constexpr char kNameForbiddenCharacters[] = " \t\n\r\v\f#,";

// "" if `name` can be written as such a field; else why not, e.g. "contains '#' (...)" or
// "is empty".
std::string NameProblem(const std::string& name);

}  // namespace aqs

#endif  // AQS_UTIL_NAME_RULES_H_
