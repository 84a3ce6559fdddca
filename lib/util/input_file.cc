#include "util/input_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace aqs {
namespace {

// What a file that is not regular is, for messages.
std::string KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

bool CheckInputFile(const std::string& path, std::string* error) {
  if (path.empty()) {
    *error = "an empty file name";
    return false;
  }
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) {
    *error = path + ": cannot open file for reading (" + std::strerror(errno) + ")";
    return false;
  }
  if (!S_ISREG(st.st_mode)) {
    *error = path + ": is " + KindOf(st.st_mode) + ", not a regular file (only regular files " +
             "are read)";
    return false;
  }
  return true;
}

bool MayExist(const std::string& path) {
  std::error_code code;
  return std::filesystem::exists(path, code) || code;
}

bool CheckOutputFile(const std::string& path, std::string* error) {
  if (path.empty()) {
    *error = "an empty output file name";
    return false;
  }
  std::string folder = ".";
  const size_t slash = path.find_last_of('/');
  if (slash != std::string::npos) folder = slash == 0 ? "/" : path.substr(0, slash);
  if (slash == path.size() - 1) {
    *error = path + ": an output file name must not end in '/'";
    return false;
  }
  struct stat st;
  if (::stat(folder.c_str(), &st) != 0) {
    *error = path + ": cannot write here: the folder " + folder + " does not exist (" +
             std::strerror(errno) + "); create it first";
    return false;
  }
  if (!S_ISDIR(st.st_mode)) {
    *error = path + ": cannot write here: " + folder + " is not a folder";
    return false;
  }
  if (::access(folder.c_str(), W_OK | X_OK) != 0) {
    *error = path + ": cannot write here: the folder " + folder + " is not writable (" +
             std::strerror(errno) + ")";
    return false;
  }
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    *error = path + ": is a directory; expected a file name";
    return false;
  }
  return true;
}

namespace {

// `path` made absolute, with symbolic links, "." and ".." resolved as far as it exists,
// without a trailing '/'.
std::string ResolvedPath(const std::string& path) {
  std::error_code code;
  const std::filesystem::path absolute = std::filesystem::absolute(path, code);
  std::filesystem::path p = std::filesystem::weakly_canonical(absolute, code);
  if (code) p = absolute.lexically_normal();
  std::string text = p.string();
  while (text.size() > 1 && text.back() == '/') text.pop_back();
  return text;
}

}  // namespace

bool CheckOutputApart(const std::string& output, const std::string& input, std::string* error) {
  if (output.empty() || input.empty()) return true;
  const std::string out = ResolvedPath(output);
  const std::string in = ResolvedPath(input);
  std::error_code code;
  if (std::filesystem::is_directory(in, code)) {
    if (out == in || out.compare(0, in.size() + 1, in + "/") == 0) {
      *error = output + ": is inside the input folder " + input +
               ", which an output must leave alone; write it elsewhere";
      return false;
    }
  } else if (out == in) {
    *error = output + ": is the input file " + input +
             " itself, which the output would overwrite; write it elsewhere";
    return false;
  }
  return true;
}

bool CheckInputOutside(const std::string& input, const std::string& replaced,
                       std::string* error) {
  if (input.empty() || replaced.empty()) return true;
  const std::string in = ResolvedPath(input);
  const std::string folder = ResolvedPath(replaced);
  if (in == folder || in.compare(0, folder.size() + 1, folder + "/") == 0) {
    *error = input + ": lies in " + replaced + ", which this job empties and writes anew; " +
             "move the input or write elsewhere";
    return false;
  }
  return true;
}

bool CheckOutputsDistinct(const std::vector<std::string>& outputs, std::string* error) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].empty()) continue;
    for (size_t j = 0; j < i; ++j) {
      std::string same;
      if (!outputs[j].empty() && !CheckOutputApart(outputs[i], outputs[j], &same)) {
        *error = outputs[i] + ": given for two outputs; each needs its own file";
        return false;
      }
    }
  }
  return true;
}

}  // namespace aqs
