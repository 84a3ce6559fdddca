#ifndef AQS_UTIL_FILE_EXTENSION_H_
#define AQS_UTIL_FILE_EXTENSION_H_

#include <string>

namespace aqs {

// The extension of the file name in `path`, lower-cased, with its dot, as
// std::filesystem::path::extension() takes it: "dir.d/Mesh.MSH" -> ".msh",
// "a/b.tar.gz" -> ".gz", "dir.d/mesh" -> "", "dir/.obj" -> "" (a name that starts with its
// only dot has no extension), "a/" -> "". Only ASCII letters are lower-cased. The
// readers and jobs choose a file format by it.
std::string LowercaseExtension(const std::string& path);

}  // namespace aqs

#endif  // AQS_UTIL_FILE_EXTENSION_H_
