#include "util/line_reader.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>

namespace aqs {

LineReader::LineReader(const std::string& path) : path_(path), stream_(path) {
  if (!stream_) {
    error_ = path + ": cannot open file for reading (" + std::strerror(errno) + ")";
    return;
  }
  ok_ = true;
}

bool LineReader::NextLine() {
  if (!ok_) return false;
  if (!std::getline(stream_, line_)) return false;
  ++line_number_;
  if (!line_.empty() && line_.back() == '\r') line_.pop_back();
  return true;
}

bool LineReader::NextTokens(std::vector<std::string>* tokens, char comment_char) {
  while (NextLine()) {
    std::string content = line_;
    if (comment_char != '\0') {
      const size_t pos = content.find(comment_char);
      if (pos != std::string::npos) content.resize(pos);
    }
    *tokens = SplitTokens(content);
    if (!tokens->empty()) return true;
  }
  tokens->clear();
  return false;
}

std::string LineReader::Where(const std::string& message) const {
  std::ostringstream out;
  out << path_;
  if (line_number_ > 0) out << ":" << line_number_;
  out << ": " << message;
  return out.str();
}

std::vector<std::string> SplitTokens(const std::string& text) {
  std::vector<std::string> tokens;
  std::istringstream in(text);
  std::string token;
  while (in >> token) tokens.push_back(token);
  return tokens;
}

bool ParseDouble(const std::string& token, double* value) {
  if (token.empty()) return false;
  const char* begin = token.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end != begin + token.size() || !std::isfinite(v)) return false;
  if (errno == ERANGE && std::abs(v) > 1.0) return false;  // overflow; underflow is fine
  *value = v;
  return true;
}

bool ParseInt64(const std::string& token, long long* value) {
  if (token.empty()) return false;
  const char* begin = token.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (end != begin + token.size() || errno == ERANGE) return false;
  *value = v;
  return true;
}

bool ParseInt(const std::string& token, int* value) {
  long long v = 0;
  if (!ParseInt64(token, &v)) return false;
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) return false;
  *value = static_cast<int>(v);
  return true;
}

}  // namespace aqs
