#include "util/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace aqs {

AtomicFileWriter::AtomicFileWriter(const std::string& path)
    : path_(path),
      temp_path_(path + ".tmp" + std::to_string(static_cast<long>(::getpid()))),
      stream_(temp_path_, std::ios::out | std::ios::trunc | std::ios::binary) {}

AtomicFileWriter::~AtomicFileWriter() {
  if (!committed_) {
    stream_.close();
    std::remove(temp_path_.c_str());
  }
}

bool AtomicFileWriter::Commit(std::string* error) {
  if (!stream_.is_open()) {
    *error = path_ + ": cannot create temporary file " + temp_path_ + " (" +
             std::strerror(errno) + ")";
    return false;
  }
  stream_.flush();
  const bool write_ok = static_cast<bool>(stream_);
  stream_.close();
  if (!write_ok || stream_.fail()) {
    *error = path_ + ": write failed (disk full or I/O error)";
    std::remove(temp_path_.c_str());
    committed_ = true;
    return false;
  }
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    *error = path_ + ": cannot move temporary file into place (" + std::strerror(errno) + ")";
    std::remove(temp_path_.c_str());
    committed_ = true;
    return false;
  }
  committed_ = true;
  return true;
}

bool WriteFileAtomically(const std::string& path, const std::string& content,
                         std::string* error) {
  AtomicFileWriter writer(path);
  writer.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  return writer.Commit(error);
}

}  // namespace aqs
