// A small tmpfs mounted for a test: a real full disk and a real read-only file system for the
// map server's files (mount(2) needs root or CAP_SYS_ADMIN; without it ok() is false and why()
// says so, for GTEST_SKIP). Unmounted when destroyed, also after a failed assertion.
#pragma once

#include <fcntl.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

namespace fuse::test {

class TmpfsMount {
 public:
  TmpfsMount(const std::filesystem::path& dir, std::size_t bytes) : dir_(dir), options_("size=" + std::to_string(bytes)) {
    std::filesystem::create_directories(dir_);
    if (::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options_.c_str()) != 0) {
      why_ = "cannot mount a tmpfs at " + dir_.string() + " (" + std::strerror(errno) +
             "): these tests need root (or CAP_SYS_ADMIN) to make a real full or read-only disk";
      return;
    }
    mounted_ = true;
  }
  ~TmpfsMount() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  TmpfsMount(const TmpfsMount&) = delete;
  TmpfsMount& operator=(const TmpfsMount&) = delete;

  bool ok() const { return mounted_; }
  const std::string& why() const { return why_; }
  const std::filesystem::path& path() const { return dir_; }

  /// Remounts read-only or read-write. The kernel refuses read-only while a file on it is open
  /// for writing (EBUSY): retried until timeout. False (errno in why()) when it never worked.
  bool set_read_only(bool read_only, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    const unsigned long flags = MS_REMOUNT | (read_only ? MS_RDONLY : 0);
    while (::mount("tmpfs", dir_.c_str(), "tmpfs", flags, options_.c_str()) != 0) {
      why_ = std::string("remount ") + (read_only ? "ro" : "rw") + ": " + std::strerror(errno);
      if (errno != EBUSY || std::chrono::steady_clock::now() >= end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

  /// Writes a file `name` until the file system is full (to its last page); returns its size.
  std::uint64_t fill(const std::string& name = "filler") {
    const std::filesystem::path file = dir_ / name;
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd < 0) return 0;
    std::uint64_t written = 0;
    for (const std::size_t block : {std::size_t{1} << 16, std::size_t{4096}, std::size_t{1}}) {
      const std::vector<char> bytes(block, 'x');
      for (;;) {
        const ssize_t n = ::write(fd, bytes.data(), bytes.size());
        if (n <= 0) break;
        written += static_cast<std::uint64_t>(n);
      }
    }
    ::close(fd);
    return written;
  }
  void remove(const std::string& name = "filler") {
    std::error_code ec;
    std::filesystem::remove(dir_ / name, ec);
  }

 private:
  std::filesystem::path dir_;
  std::string options_;
  bool mounted_ = false;
  std::string why_;
};

}  // namespace fuse::test
