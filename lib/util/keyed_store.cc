#include "util/keyed_store.h"

#include <cstdio>
#include <filesystem>

#include "util/atomic_file.h"
#include "util/make_directory.h"

namespace aqs {

namespace fs = std::filesystem;

bool KeyedStore::Open(const std::string& directory, const std::string& key, std::string* error) {
  directory_.clear();
  std::error_code code;
  const std::string key_path = directory + "/key.txt";
  if (fs::exists(directory, code) && ReadWholeFile(key_path) != key) {
    for (const fs::directory_entry& entry : fs::directory_iterator(directory, code)) {
      fs::remove_all(entry.path(), code);
      if (code) {
        *error = entry.path().string() + ": cannot remove (" + code.message() + ")";
        return false;
      }
    }
    if (code) {
      *error = directory + ": cannot list (" + code.message() + ")";
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
