#include "util/keyed_store.h"

#include <cstdio>
#include <filesystem>

#include "util/atomic_file.h"
#include "util/make_directory.h"

namespace aqs {

namespace fs = std::filesystem;

std::string KeyedStore::PreviousPath(const std::string& directory) {
  return directory + ".previous";
}

bool KeyedStore::Open(const std::string& directory, const std::string& key, std::string* error) {
  directory_.clear();
  std::error_code code;
  const std::string key_path = directory + "/key.txt";
  if (fs::exists(directory, code) && ReadWholeFile(key_path) != key) {
    if (fs::is_empty(directory, code) && !code) {
      // Nothing to keep.
    } else {
      // Moved aside, not emptied: a rerun with one flag mistyped must not delete the
      // stopped run's work before it has made anything (one generation is kept).
      const std::string previous = PreviousPath(directory);
      fs::remove_all(previous, code);
      if (!code) fs::rename(directory, previous, code);
      if (code) {
        *error = directory + ": cannot move aside to " + previous + " (" + code.message() + ")";
        return false;
      }
    }
  }
  if (!MakeDirectory(directory, error)) return false;
  if (ReadWholeFile(key_path) != key && !WriteFileAtomically(key_path, key, error)) return false;
  directory_ = directory;
  return true;
}

std::string KeyedStore::ItemPath(int index, const char* extension) const {
  char name[32];
  std::snprintf(name, sizeof(name), "/%04d.%s", index, extension);
  return directory_ + name;
}

}  // namespace aqs
