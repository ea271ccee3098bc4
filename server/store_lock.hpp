#pragma once
// Who owns a store: an exclusive flock() held for a daemon's life, on DATA_DIR/geld.lock (the
// jobs tree) and on the SQLite file itself (the queue). Two daemons on one queue both ran its
// jobs, and the data-dir lock alone did not see a second daemon whose --db pointed at the first
// one's file from another data dir (a job ended `succeeded` twice).
#include <string>

namespace geld {

class OwnerLock {
 public:
  OwnerLock() = default;
  ~OwnerLock();
  OwnerLock(OwnerLock&& other) noexcept;
  OwnerLock& operator=(OwnerLock&& other) noexcept;
  OwnerLock(const OwnerLock&) = delete;
  OwnerLock& operator=(const OwnerLock&) = delete;

  // DATA_DIR/geld.lock, with this process's pid written into it for the next one's refusal.
  static OwnerLock data_dir(const std::string& data_dir);
  // The database file itself (created empty if missing, which SQLite takes as a new database).
  // Throws std::runtime_error naming the file and, where the kernel says, the holder's pid.
  static OwnerLock store(const std::string& db_path);

  // Lets another daemon in without closing the file: see store_lock.cpp.
  void release();
  bool held() const { return held_; }

 private:
  explicit OwnerLock(int fd) : fd_(fd), held_(true) {}
  int fd_ = -1;
  bool held_ = false;
};

}  // namespace geld
