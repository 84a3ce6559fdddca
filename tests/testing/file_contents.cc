#include "testing/file_contents.h"

#include <fstream>
#include <sstream>
#include <vector>

#include "util/text_split.h"

namespace aqs {
namespace testing {

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::string FramesCsvWithoutSeconds(const std::string& path) {
  std::ifstream in(path);
  std::string out;
  for (std::string line; std::getline(in, line);) {
    const std::vector<std::string> cells = SplitFields(line);
    for (size_t column = 0; column < cells.size(); ++column) {
      out += (column == 10 ? std::string("-") : cells[column]) + ",";
    }
    out += "\n";
  }
  return out;
}

}  // namespace testing
}  // namespace aqs
