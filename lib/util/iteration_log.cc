#include "util/iteration_log.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/text_split.h"

namespace aqs {

bool IsWholeLogRow(const std::string& line, const std::string& header) {
  const std::vector<std::string> fields = SplitFields(line);
  if (fields.size() != static_cast<size_t>(std::count(header.begin(), header.end(), ',')) + 1) {
    return false;
  }
  for (const std::string& field : fields) {
    double value = 0.0;
    if (!ParseDouble(field, &value)) return false;
  }
  return true;
}

bool PrepareIterationLog(const std::string& path, const std::string& header, int iteration,
                         int* last_row, std::string* error, std::string* last_line) {
  std::string kept = header;
  *last_row = -1;
  if (last_line != nullptr) last_line->clear();
  if (iteration > 0) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      int it = -1;
      if (std::sscanf(line.c_str(), "%d,", &it) == 1 && it > *last_row && it <= iteration &&
          IsWholeLogRow(line, header)) {
        kept += line + "\n";
        *last_row = it;
        if (last_line != nullptr) *last_line = line;
      }
    }
  }
  return WriteFileAtomically(path, kept, error);
}

bool AppendLogRow(const std::string& path, const std::string& row, std::string* error) {
  // A log that does not end in a newline ends in part of a row (an append that failed
  // when the disk was full, or a kill): the row goes on a line of its own, not glued to
  // that part (which readers then skip as a malformed row).
  bool partial = false;
  if (std::FILE* in = std::fopen(path.c_str(), "rb")) {
    partial = std::fseek(in, -1, SEEK_END) == 0 && std::fgetc(in) != '\n';
    std::fclose(in);
  }
  const std::string text = partial ? "\n" + row : row;
  std::FILE* file = std::fopen(path.c_str(), "a");
  if (file == nullptr) {
    *error = path + ": cannot append to the log (" + std::strerror(errno) + ")";
    return false;
  }
  const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size() &&
                       std::fflush(file) == 0;
  const int write_errno = errno;
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) {
    *error = path + ": cannot append to the log (" +
             std::strerror(written ? errno : write_errno) + ")";
    return false;
  }
  return true;
}

}  // namespace aqs
