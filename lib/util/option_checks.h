#ifndef AQS_UTIL_OPTION_CHECKS_H_
#define AQS_UTIL_OPTION_CHECKS_H_

#include <string>

namespace aqs {

// The checks of an Options struct's Validate(std::string* error) (in the style of
// Ceres' Solver::Options::IsValid): each check names its field as the struct spells it,
// nested structs' fields with their member's name first ("solver.num_threads"), and the
// first failed check is the message, which starts with the field's name:
//
//   bool FooOptions::Validate(std::string* error) const {
//     std::string solver_error;
//     return OptionChecks()
//         .Positive("thickness", thickness)
//         .IntInRange("path_steps", path_steps, 0, 1000)
//         .Nested("solver", solver.Validate(&solver_error), solver_error)
//         .Done(error);
//   }
//
// Apps translate the field names at the start of such messages to their flags
// (apps/app_common.h, FlagError). Messages look like "thickness must be finite and > 0
// (is nan)".
class OptionChecks {
 public:
  // value finite and > 0.
  OptionChecks& Positive(const char* field, double value);
  // value finite and >= 0.
  OptionChecks& NonNegative(const char* field, double value);
  // value finite and in [lowest, highest].
  OptionChecks& InRange(const char* field, double value, double lowest, double highest);
  // value in [lowest, highest] (integers).
  OptionChecks& IntInRange(const char* field, long long value, long long lowest,
                           long long highest);
  // value >= lowest (integers).
  OptionChecks& IntAtLeast(const char* field, long long value, long long lowest);
  // A relative force tolerance of the equilibrium solves (QuasistaticSolverOptions::
  // relative_force_tolerance) that solves can reach and that asks for a solve: in
  // [kMinReachableRelativeTolerance, kMaxRelativeTolerance]. Below, the force test meets
  // round-off and a solve may run on for minutes (the finger at 1e-14: more than 2
  // minutes; at 1e-13: 0.7 s, converged); above, a solve stops where it starts (1e300
  // "converged" with no iterations, and prepare wrote targets it never solved).
  OptionChecks& ReachableTolerance(const char* field, double value);
  // A nested struct's Validate result: its message gets "<prefix>." in front.
  OptionChecks& Nested(const char* prefix, bool ok, const std::string& nested_error);
  // Any other condition; `message` must start with the field's name.
  OptionChecks& Require(bool condition, const std::string& message);

  // True if every check passed; else false with *error the first failure.
  bool Done(std::string* error) const;

 private:
  bool Failed() const { return !error_.empty(); }
  std::string error_;
};

// The largest weight of a latent regularizer the options accept: the data terms are
// mean squared distances (model units^2), so a weight of 1e6 already pins every latent
// to 0; far larger ones overflow the gradients.
constexpr double kMaxRegularization = 1e6;

// The smallest relative force tolerance the jobs accept (README: about 1e-13 is
// reachable), and the largest (a tenth of the force scale).
constexpr double kMinReachableRelativeTolerance = 1e-13;
constexpr double kMaxRelativeTolerance = 0.1;

// `value` for messages: "nan", "inf", "-1", "1e-09", ...
std::string OptionValue(double value);

}  // namespace aqs

#endif  // AQS_UTIL_OPTION_CHECKS_H_
