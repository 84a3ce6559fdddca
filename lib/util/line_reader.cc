#include "util/line_reader.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>

#include "util/input_file.h"

namespace aqs {

namespace {

constexpr size_t kBufferBytes = 1 << 16;

}  // namespace

LineReader::LineReader(const std::string& path) : path_(path) {
  if (!CheckInputFile(path, &error_)) return;
  stream_.open(path, std::ios::binary);
  if (!stream_) {
    error_ = path + ": cannot open file for reading (" + std::strerror(errno) + ")";
    return;
  }
  buffer_.resize(kBufferBytes);
  ok_ = true;
}

bool LineReader::Fill() {
  begin_ = end_ = 0;
  stream_.read(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
  end_ = static_cast<size_t>(stream_.gcount());
  if (end_ == 0 && stream_.bad()) {
    ok_ = false;
    error_ = Where("read error");
  }
  return end_ > 0;
}

bool LineReader::NextLine() {
  if (!ok_) return false;
  line_.clear();
  bool any = false;  // a byte (or the newline) of this line was read
  while (true) {
    if (begin_ == end_ && !Fill()) break;
    any = true;
    const char* start = buffer_.data() + begin_;
    const size_t available = end_ - begin_;
    const char* newline = static_cast<const char*>(std::memchr(start, '\n', available));
    const size_t take = newline != nullptr ? static_cast<size_t>(newline - start) : available;
    if (line_.size() + take > static_cast<size_t>(kMaxLineBytes)) {
      ok_ = false;
      line_.clear();
      std::ostringstream out;
      out << path_ << ":" << line_number_ + 1 << ": the line is longer than " << kMaxLineBytes
          << " bytes, the longest a text file may have (not a text file of this format?)";
      error_ = out.str();
      return false;
    }
    line_.append(start, take);
    begin_ += take;
    if (newline != nullptr) {
      ++begin_;
      break;
    }
  }
  if (!ok_ || !any) return false;
  ++line_number_;
  if (!line_.empty() && line_.back() == '\r') line_.pop_back();
  // A UTF-8 byte-order mark (some Windows editors save one) is not part of the text:
  // left in, it hid the first record ("\xEF\xBB\xBFv" is no 'v').
  if (line_number_ == 1 && line_.compare(0, 3, "\xEF\xBB\xBF") == 0) line_.erase(0, 3);
  return true;
}

bool LineReader::NextTokens(std::vector<std::string>* tokens, char comment_char) {
  while (NextLine()) {
    SplitTokens(line_, comment_char, tokens);
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

namespace {

inline bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

}  // namespace

void SplitTokens(const std::string& line, char comment_char, std::vector<std::string>* tokens) {
  size_t count = 0;
  const char* p = line.data();
  const char* end = p + line.size();
  if (comment_char != '\0') {
    for (const char* q = p; q != end; ++q) {
      if (*q == comment_char) {
        end = q;
        break;
      }
    }
  }
  while (true) {
    while (p != end && IsSpace(*p)) ++p;
    if (p == end) break;
    const char* start = p;
    while (p != end && !IsSpace(*p)) ++p;
    if (count < tokens->size()) {
      (*tokens)[count].assign(start, p);
    } else {
      tokens->emplace_back(start, p);
    }
    ++count;
  }
  tokens->resize(count);
}

std::vector<std::string> SplitTokens(const std::string& text) {
  std::vector<std::string> tokens;
  SplitTokens(text, '\0', &tokens);
  return tokens;
}

namespace {

// [+-]digits[.digits][(e|E)[+-]digits], digits on at least one side of the point.
bool IsDecimalNumber(const std::string& token) {
  size_t i = 0;
  const size_t n = token.size();
  auto digits = [&]() {
    const size_t start = i;
    while (i < n && token[i] >= '0' && token[i] <= '9') ++i;
    return i - start;
  };
  if (i < n && (token[i] == '+' || token[i] == '-')) ++i;
  size_t mantissa = digits();
  if (i < n && token[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < n && (token[i] == 'e' || token[i] == 'E')) {
    ++i;
    if (i < n && (token[i] == '+' || token[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  return i == n;
}

}  // namespace

bool ParseDouble(const std::string& token, double* value) {
  if (!IsDecimalNumber(token)) return false;
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
  const size_t first = token[0] == '+' || token[0] == '-' ? 1 : 0;
  if (first == token.size()) return false;
  for (size_t i = first; i < token.size(); ++i) {
    if (token[i] < '0' || token[i] > '9') return false;
  }
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

std::string Quoted(const std::string& token) {
  constexpr size_t kMaxShown = 40;
  std::string out = "'";
  const size_t shown = std::min(token.size(), kMaxShown);
  for (size_t i = 0; i < shown; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    if (std::isprint(c)) {
      out.push_back(static_cast<char>(c));
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02X", c);
      out += escaped;
    }
  }
  if (token.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

}  // namespace aqs
