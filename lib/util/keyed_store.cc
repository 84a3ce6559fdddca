#include "util/keyed_store.h"

#include <fcntl.h>
#include <stdio.h>

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
  const std::string previous = PreviousPath(directory);
  // The generation moved aside, if it is this key's (a run stopped, then a rerun with a
  // mistyped flag, then this run again): taken back, not replaced by the mistyped one.
  const bool previous_is_ours = ReadWholeFile(previous + "/key.txt") == key;
  if (fs::exists(directory, code) && ReadWholeFile(key_path) != key) {
    const bool empty = fs::is_empty(directory, code) && !code;
    code.clear();  // a folder whose emptiness cannot be told is moved as a full one
    if (previous_is_ours) {
      // The two folders trade places (atomically where the file system can).
      if (::renameat2(AT_FDCWD, directory.c_str(), AT_FDCWD, previous.c_str(),
                      RENAME_EXCHANGE) != 0) {
        const std::string aside = directory + ".exchange";
        fs::remove_all(aside, code);
        if (!code) fs::rename(directory, aside, code);
        if (!code) fs::rename(previous, directory, code);
        if (!code) fs::rename(aside, previous, code);
      }
      if (!code && empty) fs::remove_all(previous, code);
    } else if (!empty) {
      // Moved aside, not emptied: a rerun with one flag mistyped must not delete the
      // stopped run's work before it has made anything (one generation is kept).
      fs::remove_all(previous, code);
      if (!code) fs::rename(directory, previous, code);
    }
    if (code) {
      *error = directory + ": cannot move aside to " + previous + " (" + code.message() + ")";
      return false;
    }
  } else if (!fs::exists(directory, code) && previous_is_ours) {
    fs::rename(previous, directory, code);
    if (code) {
      *error = previous + ": cannot move back to " + directory + " (" + code.message() + ")";
      return false;
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
