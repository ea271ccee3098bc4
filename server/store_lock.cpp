#include "store_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <spdlog/spdlog.h>

namespace geld {
namespace fs = std::filesystem;

namespace {

// flock() rather than fcntl(): SQLite takes POSIX (fcntl) locks on its file, which on Linux are
// independent of flock, so ours neither blocks SQLite nor is dropped by SQLite's own locking.
// A flock belongs to the inode, so a symlink, a hard link or another spelling of the path meets
// the same lock, and the kernel drops it when the holder dies (SIGKILL leaves nothing stale).
// (On NFS the kernel emulates flock with a whole-file POSIX lock; SQLite on NFS is unsafe anyway.)
int open_and_lock(const std::string& path, const char* what) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(std::string("cannot open ") + what + " " + path + ": " + std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return fd;
  if (errno == EWOULDBLOCK) return -1 - fd;  // busy: the caller names the holder, then closes
  const int error = errno;
  ::close(fd);
  throw std::runtime_error(std::string("cannot lock ") + what + " " + path + ": " + std::strerror(error));
}

// The pid the kernel lists for a flock on the file of `fd` (/proc/locks), or "" if none shows
// (another pid namespace, /proc not mounted): the store file has no room for a pid of ours.
std::string flock_holder(int fd) {
  struct stat info {};
  if (::fstat(fd, &info) != 0) return "";
  std::ifstream locks("/proc/locks");
  std::string line;
  while (std::getline(locks, line)) {
    // "1: FLOCK  ADVISORY  WRITE 1234 fe:00:10953495 0 EOF" (device in hex, inode in decimal)
    std::istringstream fields(line);
    std::string number, kind, mode, access, pid, file;
    if (!(fields >> number >> kind >> mode >> access >> pid >> file) || kind != "FLOCK") continue;
    unsigned major = 0, minor = 0;
    unsigned long long inode = 0;
    if (std::sscanf(file.c_str(), "%x:%x:%llu", &major, &minor, &inode) != 3) continue;
    if (inode == static_cast<unsigned long long>(info.st_ino) && major == ::major(info.st_dev) &&
        minor == ::minor(info.st_dev))
      return pid;
  }
  return "";
}

}  // namespace

OwnerLock::~OwnerLock() {
  if (fd_ >= 0) ::close(fd_);
}

OwnerLock::OwnerLock(OwnerLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), held_(std::exchange(other.held_, false)) {}

OwnerLock& OwnerLock::operator=(OwnerLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    held_ = std::exchange(other.held_, false);
  }
  return *this;
}

// LOCK_UN, not close(): closing any descriptor of a file drops every POSIX lock this process
// holds on it, SQLite's included, while the store may still be open. The descriptor is closed
// by the destructor, after the store (the owner declares the lock before the store).
void OwnerLock::release() {
  if (fd_ >= 0 && held_) ::flock(fd_, LOCK_UN);
  held_ = false;
}

OwnerLock OwnerLock::data_dir(const std::string& data_dir) {
  const std::string path = (fs::path(data_dir) / "geld.lock").string();
  int fd = open_and_lock(path, "lock file");
  if (fd < 0) {
    fd = -1 - fd;
    char holder[32] = {};
    const ssize_t n = ::pread(fd, holder, sizeof holder - 1, 0);
    ::close(fd);
    std::string pid(holder, n > 0 ? static_cast<std::size_t>(n) : 0);
    while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
    throw std::runtime_error("data dir " + data_dir + " is in use by another geld" +
                             (pid.empty() ? "" : " (pid " + pid + ")") +
                             ": two daemons on one data dir would run the same jobs");
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0)
    spdlog::warn("cannot write the pid into {}", path);
  return OwnerLock(fd);
}

OwnerLock OwnerLock::store(const std::string& db_path) {
  int fd = open_and_lock(db_path, "store");
  if (fd >= 0) return OwnerLock(fd);
  fd = -1 - fd;
  const std::string pid = flock_holder(fd);
  // A refused daemon has no store open, so this close drops no SQLite lock of its own (in a
  // process that has, like a test with two managers, it drops locks that only other processes see).
  ::close(fd);
  std::error_code ec;
  const auto real = fs::canonical(db_path, ec);
  const std::string shown = ec || real.string() == db_path ? db_path : db_path + " (" + real.string() + ")";
  throw std::runtime_error("store " + shown + " is in use by another geld" + (pid.empty() ? "" : " (pid " + pid + ")") +
                           ": two daemons on one store would run the same jobs");
}

}  // namespace geld
