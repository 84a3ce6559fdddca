#include "util/matrix_io.h"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include "util/atomic_file.h"
#include "util/input_file.h"

namespace aqs {
namespace {

constexpr char kMagic[8] = {'A', 'Q', 'S', 'M', 'A', 'T', '1', '\n'};

static_assert(sizeof(double) == 8, "IEEE-754 doubles expected");
// The files are little-endian (matrix_io.h), written and read as the host stores them.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "matrix files are little-endian: a big-endian host would need byte swaps");

}  // namespace

bool WriteMatrixFile(const std::string& path, const Eigen::MatrixXd& matrix, std::string* error) {
  AtomicFileWriter writer(path);
  const int64_t sizes[2] = {static_cast<int64_t>(matrix.rows()),
                            static_cast<int64_t>(matrix.cols())};
  writer.stream().write(kMagic, sizeof(kMagic));
  writer.stream().write(reinterpret_cast<const char*>(sizes), sizeof(sizes));
  writer.stream().write(reinterpret_cast<const char*>(matrix.data()),
                        static_cast<std::streamsize>(sizeof(double) * matrix.size()));
  return writer.Commit(error);
}

bool ReadMatrixFile(const std::string& path, Eigen::Index expected_rows, Eigen::Index expected_cols,
                    Eigen::MatrixXd* matrix, std::string* error) {
  if (!CheckInputFile(path, error)) return false;
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    *error = path + ": cannot open file for reading";
    return false;
  }
  const std::streamoff length = in.tellg();
  in.seekg(0);
  char magic[8];
  int64_t sizes[2];
  if (length < 24 || !in.read(magic, 8) || std::memcmp(magic, kMagic, 8) != 0 ||
      !in.read(reinterpret_cast<char*>(sizes), sizeof(sizes))) {
    *error = path + ": not an ActiveQS matrix file (bad header)";
    return false;
  }
  std::ostringstream out;
  if (sizes[0] < 0 || sizes[1] < 0 ||
      (sizes[0] > 0 && sizes[1] > (length - 24) / 8 / sizes[0]) ||
      24 + 8 * sizes[0] * sizes[1] != length) {
    out << path << ": header says " << sizes[0] << " x " << sizes[1] << " doubles but the file has "
        << (length - 24) << " data bytes (truncated or corrupt)";
    *error = out.str();
    return false;
  }
  if ((expected_rows >= 0 && sizes[0] != expected_rows) ||
      (expected_cols >= 0 && sizes[1] != expected_cols)) {
    out << path << ": a " << sizes[0] << " x " << sizes[1] << " matrix where "
        << (expected_rows >= 0 ? std::to_string(expected_rows) : std::string("any")) << " x "
        << (expected_cols >= 0 ? std::to_string(expected_cols) : std::string("any"))
        << " was expected";
    *error = out.str();
    return false;
  }
  Eigen::MatrixXd read(sizes[0], sizes[1]);
  if (!in.read(reinterpret_cast<char*>(read.data()),
               static_cast<std::streamsize>(sizeof(double) * read.size()))) {
    *error = path + ": read failed";
    return false;
  }
  *matrix = std::move(read);
  return true;
}

}  // namespace aqs
