#ifndef AQS_MESH_TEXT_IO_UTIL_H_
#define AQS_MESH_TEXT_IO_UTIL_H_

// Internal helpers shared by the mesh file readers and writers. Not part of the public
// API: include only from lib/mesh/*.cc (and the mesh tests).

#include <cstddef>
#include <ostream>
#include <string>
#include <vector>

#include "util/line_reader.h"

namespace aqs {
namespace mesh_internal {

// The error for a reader that returned no line where one was expected: the reader's
// own error if it failed (a line too long, a read error), else "path:line: message"
// (message saying what was expected at the end of the file).
std::string EndOfFileError(const LineReader& reader, const std::string& message);

// Size of the file in bytes, or -1 if it cannot be determined.
long long FileSizeBytes(const std::string& path);

// True if the first few kilobytes of the file contain a NUL byte (a binary file).
bool FileLooksBinary(const std::string& path);

// Checks a record count read from a file: returns false with *error ("path:line: ...",
// at the reader's current line) if it is negative, larger than the largest int, or if
// `count` records of `tokens_per_record` tokens cannot fit in a file of `file_size`
// bytes (each token takes at least one character and one separator; file_size < 0:
// unknown, not checked). `what` names the records ("vertices", "nodes", ...).
bool CheckRecordCount(const LineReader& reader, long long count, int tokens_per_record,
                      long long file_size, const std::string& what, std::string* error);

// Appends the decimal form of `value` to *out.
void AppendInt(long long value, std::string* out);

// The tokens of a file one after the other, across line ends (for formats such as
// MEDIT whose records may span lines). Where() names the line of the last token.
class TokenStream {
 public:
  TokenStream(LineReader* reader, char comment_char)
      : reader_(reader), comment_char_(comment_char) {}

  // The next token, or nullptr at end of file. Valid until the next call.
  const std::string* Next();
  // "path:line: message" for the line of the last token returned (the last line of
  // the file after Next() returned nullptr).
  std::string Where(const std::string& message) const { return reader_->Where(message); }

 private:
  LineReader* reader_;
  char comment_char_;
  std::vector<std::string> tokens_;
  size_t next_ = 0;
};

// Collects text in a buffer and hands it to `out` in chunks of about a megabyte, so
// that writing a large file needs neither a stream operation per number nor the whole
// file in memory.
class ChunkedWriter {
 public:
  explicit ChunkedWriter(std::ostream* out);
  ~ChunkedWriter() { Flush(); }
  ChunkedWriter(const ChunkedWriter&) = delete;
  ChunkedWriter& operator=(const ChunkedWriter&) = delete;

  // The buffer to append to; call MaybeFlush() after each record.
  std::string* buffer() { return &buffer_; }
  void MaybeFlush() {
    if (buffer_.size() >= kChunkBytes) Flush();
  }
  void Flush();

 private:
  static constexpr size_t kChunkBytes = 1 << 20;
  std::ostream* out_;
  std::string buffer_;
};

}  // namespace mesh_internal
}  // namespace aqs

#endif  // AQS_MESH_TEXT_IO_UTIL_H_
