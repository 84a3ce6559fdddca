#ifndef AQS_UTIL_LINE_READER_H_
#define AQS_UTIL_LINE_READER_H_

#include <fstream>
#include <string>
#include <vector>

namespace aqs {

// Reads a text file line by line and splits lines into whitespace-separated tokens,
// keeping the line number so that every parse error can name "path:line".
// Used by all text readers of user files. Not thread-safe.
//
// Only regular files are read (CheckInputFile: a FIFO or a device is refused before it
// is opened), and no line may be longer than kMaxLineBytes (util/input_file.h): such a
// line stops the reader with an error, so that memory stays bounded by the line limit
// whatever the file holds.
class LineReader {
 public:
  // Opens `path`. ok() is false (and error() says why) if the file cannot be read.
  explicit LineReader(const std::string& path);

  // False if the file could not be opened, or once a read failed (a line longer than
  // kMaxLineBytes, an I/O error): NextLine then returns false as at the end of the
  // file, so every caller that reads to the end checks ok() afterwards and reports
  // error() ("path:line: ...").
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  const std::string& path() const { return path_; }
  // 1-based number of the line last returned by NextLine/NextTokens (0 before any).
  int line_number() const { return line_number_; }
  const std::string& line() const { return line_; }

  // Reads the next raw line (trailing '\r' and, on line 1, a UTF-8 byte-order mark
  // removed). Returns false at end of file or on a read failure (then ok() is false).
  bool NextLine();
  // Reads the next line that has at least one token once everything from
  // `comment_char` on is removed (pass '\0' for no comments); splits it into tokens.
  // Returns false at end of file.
  bool NextTokens(std::vector<std::string>* tokens, char comment_char = '#');

  // "path:line: message" for the current line (or "path: message" before any line).
  std::string Where(const std::string& message) const;

 private:
  // Refills buffer_ from the stream; false at the end of the file or on an error.
  bool Fill();

  std::string path_;
  std::ifstream stream_;
  std::vector<char> buffer_;
  size_t begin_ = 0, end_ = 0;  // unread bytes of buffer_
  std::string line_;
  int line_number_ = 0;
  bool ok_ = false;
  std::string error_;
};

// Splits `line` at whitespace (' ', '\t', '\r', '\n', '\v', '\f') into *tokens,
// ignoring everything from `comment_char` on ('\0': no comments). Reuses the storage of
// *tokens, so short tokens cause no heap allocation once the vector has grown. The one
// token reader of the text formats (LineReader::NextTokens, the mesh readers).
void SplitTokens(const std::string& line, char comment_char, std::vector<std::string>* tokens);

// Splits `text` at whitespace (no comments).
std::vector<std::string> SplitTokens(const std::string& text);

// Strict number parsing: the whole token must be a decimal number (no trailing
// characters, no leading spaces). ParseDouble takes [+-]digits[.digits][(e|E)[+-]digits]
// (digits on at least one side of the point) and rejects hexadecimal ("0x10"), nan, inf
// and values that overflow a double (underflow to 0 or a denormal is fine); ParseInt and
// ParseInt64 take [+-]digits within their type's range. Return false on failure.
bool ParseDouble(const std::string& token, double* value);
bool ParseInt(const std::string& token, int* value);
bool ParseInt64(const std::string& token, long long* value);

// `token` in quotes for an error message: 'abc'; tokens longer than 40 bytes are
// shortened (with "...") and non-printable bytes escaped as \xNN, so that a damaged or
// binary file cannot print a megabyte of bytes into a message.
std::string Quoted(const std::string& token);

}  // namespace aqs

#endif  // AQS_UTIL_LINE_READER_H_
