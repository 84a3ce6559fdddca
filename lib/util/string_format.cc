#include "util/string_format.h"

#include <cstdarg>
#include <cstdio>

namespace aqs {

std::string StringPrintf(const char* format, ...) {
  va_list arguments;
  va_start(arguments, format);
  va_list copy;
  va_copy(copy, arguments);
  const int length = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  std::string text(length > 0 ? length + 1 : 1, '\0');
  if (length > 0) std::vsnprintf(text.data(), text.size(), format, arguments);
  va_end(arguments);
  text.resize(length > 0 ? length : 0);
  return text;
}

}  // namespace aqs
