#include "mesh/text_io_util.h"

#include <glog/logging.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <limits>
#include <system_error>

namespace aqs {
namespace mesh_internal {
std::string EndOfFileError(const LineReader& reader, const std::string& message) {
  return reader.ok() ? reader.Where(message) : reader.error();
}

long long FileSizeBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return -1;
  const std::streamoff size = in.tellg();
  return size < 0 ? -1 : static_cast<long long>(size);
}

bool FileLooksBinary(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  char buffer[4096];
  in.read(buffer, sizeof(buffer));
  const std::streamsize n = in.gcount();
  return std::find(buffer, buffer + n, '\0') != buffer + n;
}

bool CheckRecordCount(const LineReader& reader, long long count, int tokens_per_record,
                      long long file_size, const std::string& what, std::string* error) {
  CHECK_GE(tokens_per_record, 1);
  if (count < 0) {
    *error = reader.Where("the number of " + what + " must not be negative, got " +
                          std::to_string(count));
    return false;
  }
  if (count > std::numeric_limits<int>::max()) {
    *error =
        reader.Where("the number of " + what + " (" + std::to_string(count) + ") is too large");
    return false;
  }
  if (file_size >= 0) {
    // A record of k tokens takes at least 2k - 1 bytes; all but the last 2k.
    const long long capacity = (file_size + 1) / (2LL * tokens_per_record);
    if (count > capacity) {
      *error = reader.Where("the number of " + what + " (" + std::to_string(count) +
                            ") is larger than the file (" + std::to_string(file_size) +
                            " bytes) can hold: the file is truncated or the count is wrong");
      return false;
    }
  }
  return true;
}

void AppendInt(long long value, std::string* out) {
  char buffer[24];
  const std::to_chars_result result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out->append(buffer, result.ptr);
}

const std::string* TokenStream::Next() {
  while (next_ >= tokens_.size()) {
    if (!reader_->NextLine()) return nullptr;
    SplitTokens(reader_->line(), comment_char_, &tokens_);
    next_ = 0;
  }
  return &tokens_[next_++];
}

ChunkedWriter::ChunkedWriter(std::ostream* out) : out_(out) { buffer_.reserve(kChunkBytes + 4096); }

void ChunkedWriter::Flush() {
  if (!buffer_.empty()) {
    out_->write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }
}

}  // namespace mesh_internal
}  // namespace aqs
