#include "io/actuation_io.h"

#include <sstream>
#include <vector>

#include <Eigen/Eigenvalues>

#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/finite_values.h"

namespace aqs {
namespace {

// Reads `count` lines of `width` numbers each into a column-major width x count block;
// *lines (if not null) receives each row's line number.
bool ReadFixedWidthRows(const std::string& path, int count, int width, const char* what,
                        std::vector<double>* values, std::string* error,
                        std::vector<int>* lines = nullptr) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  values->assign(static_cast<size_t>(count) * width, 0.0);
  std::vector<std::string> tokens;
  int row = 0;
  while (reader.NextTokens(&tokens)) {
    if (row == count) {
      std::ostringstream out;
      out << "more lines than the mesh's " << count << " elements (one " << what
          << " line per element)";
      *error = reader.Where(out.str());
      return false;
    }
    if (static_cast<int>(tokens.size()) != width) {
      std::ostringstream out;
      out << "expected " << width << " numbers (" << what << ") for element " << row << ", got "
          << tokens.size();
      *error = reader.Where(out.str());
      return false;
    }
    for (int c = 0; c < width; ++c) {
      if (!ParseDouble(tokens[c], &(*values)[static_cast<size_t>(row) * width + c])) {
        *error = reader.Where("expected a finite number, got " + Quoted(tokens[c]));
        return false;
      }
    }
    if (lines != nullptr) lines->push_back(reader.line_number());
    ++row;
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (row != count) {
    std::ostringstream out;
    out << path << ": " << row << " " << what << " lines for a mesh of " << count
        << " elements (one line per element, in mesh order)";
    *error = out.str();
    return false;
  }
  return true;
}

// The elements of the 6 x n actuations at `data` (column-major) whose S's eigenvalues
// (increasing) `accept` refuses: their count, and the first one's index and eigenvalues in
// *first (-1 if none) and *first_eigenvalues (may be null).
template <typename Accept>
int CountRefusedTargets(const double* data, Eigen::Index n, const Accept& accept, int* first,
                        Eigen::Vector3d* first_eigenvalues) {
  int count = 0;
  *first = -1;
  for (Eigen::Index e = 0; e < n; ++e) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(
        SymmetricFromActuation(data + 6 * e), Eigen::EigenvaluesOnly);
    if (accept(eigen.eigenvalues())) continue;
    if (count++ == 0) {
      *first = static_cast<int>(e);
      if (first_eigenvalues != nullptr) *first_eigenvalues = eigen.eigenvalues();
    }
  }
  return count;
}

}  // namespace

bool ReadActuation(const std::string& path, int num_elements, ActuationMatrix* a,
                   std::string* error) {
  std::vector<double> values;
  if (!ReadFixedWidthRows(path, num_elements, 6, "sxx syy szz sxy sxz syz", &values, error)) {
    return false;
  }
  *a = Eigen::Map<const ActuationMatrix>(values.data(), 6, num_elements);
  return true;
}

bool ReadActuationTargets(const std::string& path, int num_elements, ActuationMatrix* a,
                          std::string* error) {
  std::vector<double> values;
  std::vector<int> lines;
  if (!ReadFixedWidthRows(path, num_elements, 6, "sxx syy szz sxy sxz syz", &values, error,
                          &lines)) {
    return false;
  }
  const Eigen::Map<const ActuationMatrix> read(values.data(), 6, num_elements);
  int first = -1;
  Eigen::Vector3d first_eigenvalues = Eigen::Vector3d::Zero();
  const int bad = CountRefusedTargets(
      values.data(), num_elements,
      [](const Eigen::Vector3d& lambda) {
        return lambda[0] >= kMinActuationStretch && lambda[2] <= kMaxActuationStretch;
      },
      &first, &first_eigenvalues);
  if (bad > 0) {
    std::ostringstream out;
    out.precision(6);
    out << path << ":" << lines[first] << ": " << bad << " of " << num_elements
        << " actuations are not positive definite with principal stretches in ["
        << kMinActuationStretch << ", " << kMaxActuationStretch << "]; the first, element "
        << first << ", has eigenvalues " << first_eigenvalues[0] << ", " << first_eigenvalues[1]
        << ", " << first_eigenvalues[2]
        << " (S = I is rest; such a target asks the element to collapse, invert or blow up)";
    *error = out.str();
    return false;
  }
  *a = read;
  return true;
}

bool CheckStoredTargets(const std::string& source, const ActuationMatrix& a, std::string* error) {
  int first = -1;
  Eigen::Vector3d first_eigenvalues = Eigen::Vector3d::Zero();
  const int bad = CountRefusedTargets(
      a.data(), a.cols(),
      [](const Eigen::Vector3d& lambda) {
        const double largest = lambda.cwiseAbs().maxCoeff();
        return largest >= kMinActuationStretch && largest <= kMaxActuationStretch;
      },
      &first, &first_eigenvalues);
  if (bad == 0) return true;
  std::ostringstream out;
  out.precision(6);
  out << source << ": " << bad << " of " << a.cols()
      << " targets have their largest principal stretch (in magnitude) outside ["
      << kMinActuationStretch << ", " << kMaxActuationStretch << "]; the first, element "
      << first << ", has eigenvalues " << first_eigenvalues[0] << ", " << first_eigenvalues[1]
      << ", " << first_eigenvalues[2]
      << " (no embedded simulation gives such a target: a damaged file?)";
  *error = out.str();
  return false;
}

int CountNonPositiveDefinite(const ActuationMatrix& a, int* first) {
  int first_refused = -1;
  const int count = CountRefusedTargets(
      a.data(), a.cols(), [](const Eigen::Vector3d& lambda) { return lambda[0] > 0.0; },
      &first_refused, nullptr);
  if (first != nullptr) *first = first_refused;
  return count;
}

bool WriteActuation(const std::string& path, const ActuationMatrix& values,
                    const std::string& header, std::string* error) {
  if (!AllFiniteForWriting(path, values, "element", error)) return false;
  std::string text;
  text.reserve(static_cast<size_t>(values.cols()) * 6 * 24 + 256);
  if (!header.empty()) {
    std::istringstream lines(header);
    std::string line;
    while (std::getline(lines, line)) text += "# " + line + "\n";
  }
  for (Eigen::Index e = 0; e < values.cols(); ++e) {
    for (int k = 0; k < 6; ++k) {
      if (k > 0) text += ' ';
      AppendDouble(values(k, e), &text);
    }
    text += '\n';
  }
  return WriteFileAtomically(path, text, error);
}

bool ReadScalarsPerLine(const std::string& path, int count, bool require_positive,
                        Eigen::VectorXd* values, std::string* error) {
  std::vector<double> raw;
  std::vector<int> lines;
  if (!ReadFixedWidthRows(path, count, 1, "value", &raw, error, &lines)) return false;
  if (require_positive) {
    for (int i = 0; i < count; ++i) {
      if (!(raw[i] > 0.0)) {
        std::ostringstream out;
        out << path << ":" << lines[i] << ": the value for element " << i << " is " << raw[i]
            << "; it must be positive";
        *error = out.str();
        return false;
      }
    }
  }
  *values = Eigen::Map<const Eigen::VectorXd>(raw.data(), count);
  return true;
}

}  // namespace aqs
