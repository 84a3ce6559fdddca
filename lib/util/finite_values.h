#ifndef AQS_UTIL_FINITE_VALUES_H_
#define AQS_UTIL_FINITE_VALUES_H_

#include <string>

#include <Eigen/Core>

namespace aqs {

// For writers whose files the project's readers must read back (they refuse nan and
// inf): true if every entry of `values` (rows x cols; column c is `item` c, e.g. vertex
// c) is finite; else false with *error "<path>: <item> <c> has a number that is not
// finite (<value>); nothing was written" for the first such column.
bool AllFiniteForWriting(const std::string& path, const Eigen::Ref<const Eigen::MatrixXd>& values,
                         const std::string& item, std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_FINITE_VALUES_H_
