#ifndef AQS_UTIL_LINE_READER_H_
#define AQS_UTIL_LINE_READER_H_

#include <fstream>
#include <string>
#include <vector>

namespace aqs {

// Reads a text file line by line and splits lines into whitespace-separated tokens,
// keeping the line number so that every parse error can name "path:line".
// Used by all text readers of user files. Not thread-safe.
class LineReader {
 public:
  // Opens `path`. ok() is false (and error() says why) if the file cannot be read.
  explicit LineReader(const std::string& path);

  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  const std::string& path() const { return path_; }
  // 1-based number of the line last returned by NextLine/NextTokens (0 before any).
  int line_number() const { return line_number_; }
  const std::string& line() const { return line_; }

  // Reads the next raw line (trailing '\r' removed). Returns false at end of file.
  bool NextLine();
  // Reads the next line that has at least one token once everything from
  // `comment_char` on is removed (pass '\0' for no comments); splits it into tokens.
  // Returns false at end of file.
  bool NextTokens(std::vector<std::string>* tokens, char comment_char = '#');

  // "path:line: message" for the current line (or "path: message" before any line).
  std::string Where(const std::string& message) const;

 private:
  std::string path_;
  std::ifstream stream_;
  std::string line_;
  int line_number_ = 0;
  bool ok_ = false;
  std::string error_;
};

// Splits `text` at whitespace.
std::vector<std::string> SplitTokens(const std::string& text);

// Strict number parsing: the whole token must be a number (no trailing characters);
// ParseDouble rejects nan and inf. Return false on failure.
bool ParseDouble(const std::string& token, double* value);
bool ParseInt(const std::string& token, int* value);
bool ParseInt64(const std::string& token, long long* value);

}  // namespace aqs

#endif  // AQS_UTIL_LINE_READER_H_
