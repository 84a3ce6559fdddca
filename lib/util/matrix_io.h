#ifndef AQS_UTIL_MATRIX_IO_H_
#define AQS_UTIL_MATRIX_IO_H_

#include <string>

#include <Eigen/Core>

namespace aqs {

// A binary file holding one dense double matrix, for bulky model data (pose surfaces,
// volumetric targets, equilibrium states):
//   bytes 0..7    the magic "AQSMAT1\n"
//   bytes 8..15   rows, int64 little-endian
//   bytes 16..23  cols, int64 little-endian
//   then rows*cols IEEE-754 doubles, little-endian, column-major (Eigen's order).
// Writing is atomic. Reading checks the magic, the sizes against the file length and,
// when expected_rows / expected_cols are >= 0, against those; errors name the file.
bool WriteMatrixFile(const std::string& path, const Eigen::MatrixXd& matrix, std::string* error);
bool ReadMatrixFile(const std::string& path, Eigen::Index expected_rows, Eigen::Index expected_cols,
                    Eigen::MatrixXd* matrix, std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_MATRIX_IO_H_
