#include "util/file_list.h"

#include <glob.h>

#include <algorithm>
#include <filesystem>

#include "util/file_extension.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/text_split.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// Paths found by name (a folder's or a glob's), sorted, each its own origin.
void AddSorted(std::vector<std::string> found, std::vector<ListedFile>* files) {
  std::sort(found.begin(), found.end());
  for (const std::string& path : found) files->push_back({path, path});
}

bool ReadListFile(const std::string& spec, const FileListOptions& options,
                  std::vector<ListedFile>* files, std::string* error) {
  LineReader reader(spec);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  const fs::path base =
      options.base_dir.empty() ? fs::path(spec).parent_path() : fs::path(options.base_dir);
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens)) {
    if (tokens.size() != 1) {
      *error = reader.Where("expected one " + options.what + " per line (a list of files)" +
                            options.list_hint);
      return false;
    }
    fs::path p(tokens[0]);
    if (!options.default_extension.empty() && !p.has_extension()) p += options.default_extension;
    const std::string resolved = p.is_absolute() ? p.string() : (base / p).string();
    if (!MayExist(resolved)) {
      *error = reader.Where(options.what + " '" + resolved + "' does not exist");
      return false;
    }
    files->push_back({resolved, spec + ":" + std::to_string(reader.line_number())});
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  return true;
}

}  // namespace

bool ResolveFileList(const std::string& spec, const FileListOptions& options,
                     std::vector<ListedFile>* files, std::string* error) {
  files->clear();
  std::error_code code;
  std::vector<std::string> found;
  if (fs::is_directory(spec, code)) {
    for (const auto& entry : fs::directory_iterator(spec, code)) {
      const std::string ext = LowercaseExtension(entry.path().string());
      std::error_code entry_code;
      if (entry.is_regular_file(entry_code) &&
          std::find(options.folder_extensions.begin(), options.folder_extensions.end(), ext) !=
              options.folder_extensions.end()) {
        found.push_back(entry.path().string());
      }
    }
    AddSorted(found, files);
  } else if (spec.find_first_of("*?[") != std::string::npos) {
    glob_t matches;
    if (glob(spec.c_str(), 0, nullptr, &matches) == 0) {
      for (size_t i = 0; i < matches.gl_pathc; ++i) found.push_back(matches.gl_pathv[i]);
    }
    globfree(&matches);
    AddSorted(found, files);
  } else if (LowercaseExtension(spec) == ".txt" && spec.find(',') == std::string::npos) {
    return ReadListFile(spec, options, files, error);
  } else {
    for (const std::string& item : SplitList(spec)) {
      if (!MayExist(item)) {
        *error = options.what + " '" + item + "' does not exist";
        return false;
      }
      files->push_back({item, item});
    }
  }
  return true;
}

}  // namespace aqs
