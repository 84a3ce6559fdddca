#ifndef AQS_UTIL_FILE_LIST_H_
#define AQS_UTIL_FILE_LIST_H_

#include <string>
#include <vector>

namespace aqs {

// One file of a list (ResolveFileList): its path, and where it was listed
// ("list.txt:3" for a list file's line 3, else the path itself).
struct ListedFile {
  std::string path;
  std::string origin;
};

struct FileListOptions {
  // A folder's files that are kept: these extensions, lowercase with the dot (".obj").
  std::vector<std::string> folder_extensions;
  // Appended to a list file's entries that have no extension ("" : none).
  std::string default_extension;
  // A list file's relative entries are resolved in this folder ("" : the list's own).
  std::string base_dir;
  // Names the files in messages: "<what> 'x' does not exist".
  std::string what = "file";
  // Appended to the message of a .txt list with a line that is not one path (for a
  // .txt that was meant as one file, not as a list).
  std::string list_hint;
};

// The files a specification names, the one way every app lists files (pose sets,
// sequences of targets):
//   a folder      its regular files with one of options.folder_extensions, by name;
//   a glob        ("*", "?" or "[" in it) its matches, by name;
//   a .txt file   a list, one path per line ('#' comments), in that order;
//   otherwise     a comma-separated list of paths, in that order.
// Listed paths must exist. Returns false with *error naming the list's line or the
// path; an empty result is not an error (the caller names what it expected).
bool ResolveFileList(const std::string& spec, const FileListOptions& options,
                     std::vector<ListedFile>* files, std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_FILE_LIST_H_
