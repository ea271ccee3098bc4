#pragma once
// An output file the writers append to with positioned writes (gel::write_at), so that a full
// disk surfaces as NoSpaceError like every other file the engine writes.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>

#include "gel/configuration.hpp"
#include "gel/errors.hpp"

namespace gel::exporting {

class OutputFile {
 public:
  // truncate: start empty; otherwise keep the contents and append after them.
  OutputFile(const std::string& path, bool truncate) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | (truncate ? O_TRUNC : 0), 0644);
    if (fd_ < 0) throw InvalidArgument("path", "cannot create '" + path + "': " + std::strerror(errno));
    struct stat info {};
    if (::fstat(fd_, &info) == 0) end_ = static_cast<std::uint64_t>(info.st_size);
  }
  ~OutputFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void write(const void* data, std::size_t size, std::uint64_t offset) {
    gel::write_at(fd_, data, size, offset, path_);
    if (offset + size > end_) end_ = offset + size;
  }
  // Appends at the end of the file; returns where the bytes start.
  std::uint64_t append(const void* data, std::size_t size) {
    const std::uint64_t at = end_;
    write(data, size, at);
    return at;
  }
  void truncate(std::uint64_t size) {
    if (::ftruncate(fd_, static_cast<off_t>(size)) != 0)
      throw std::runtime_error("cannot truncate '" + path_ + "': " + std::strerror(errno));
    end_ = size;
  }
  bool read(void* data, std::size_t size, std::uint64_t offset) const {
    return ::pread(fd_, data, size, static_cast<off_t>(offset)) == static_cast<ssize_t>(size);
  }
  std::uint64_t size() const { return end_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  std::uint64_t end_ = 0;
};

}  // namespace gel::exporting
