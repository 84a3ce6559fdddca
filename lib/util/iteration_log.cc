#include "util/iteration_log.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
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
    // The log is the job's own: anything but a regular file (or none) in its place is
    // refused, not read (a FIFO blocked the training forever, holding the model's lock).
    std::error_code code;
    if (std::filesystem::exists(path, code) && !std::filesystem::is_regular_file(path, code)) {
      *error = path + " is not a regular file: remove it (the log is written anew)";
      return false;
    }
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

namespace {

// The length of the regular file at `path` up to its last newline, where text follows
// that newline (an unfinished row); -1 where the file ends in a newline, is empty, has
// no newline, is not a regular file (a device such as /dev/full), or cannot be read.
off_t LengthBeforeUnfinishedRow(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  struct stat info;
  off_t result = -1;
  if (::fstat(fd, &info) == 0 && S_ISREG(info.st_mode) && info.st_size > 0) {
    char block[4096];
    for (off_t end = info.st_size; end > 0 && result < 0;) {
      const off_t begin = std::max<off_t>(0, end - static_cast<off_t>(sizeof(block)));
      const ssize_t got = ::pread(fd, block, static_cast<size_t>(end - begin), begin);
      if (got != end - begin) break;
      if (end == info.st_size && block[got - 1] == '\n') break;  // ends in a newline
      for (ssize_t i = got - 1; i >= 0; --i) {
        if (block[i] == '\n') {
          result = begin + i + 1;
          break;
        }
      }
      end = begin;
    }
  }
  ::close(fd);
  return result;
}

}  // namespace

bool AppendLogRow(const std::string& path, const std::string& row, std::string* error) {
  // A log that does not end in a newline ends in part of a row (an append that failed
  // when the disk was full, or a kill). That part is cut off before the row is appended:
  // closed by a newline it could pass for a whole row with a wrong last number (12.34
  // cut to 12.). Anything else that does not end in a newline (text without one, a
  // device) keeps its text, and the row goes on a line of its own.
  bool partial = false;
  if (std::FILE* in = std::fopen(path.c_str(), "rb")) {
    partial = std::fseek(in, -1, SEEK_END) == 0 && std::fgetc(in) != '\n';
    std::fclose(in);
  }
  bool separate = false;
  if (partial) {
    const off_t keep = LengthBeforeUnfinishedRow(path);
    if (keep < 0) {
      separate = true;
    } else if (::truncate(path.c_str(), keep) != 0) {
      *error = path + ": cannot cut the partial row at the log's end (" +
               std::strerror(errno) + ")";
      return false;
    }
  }
  const std::string text = separate ? "\n" + row : row;
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
