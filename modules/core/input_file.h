#pragma once
// Reading a user's input file safely: only a regular file (never a FIFO, a
// device such as /dev/zero, a socket or a directory), only up to a stated
// size, checked on the open descriptor before anything is read or allocated.
// Header only, so that device plugins (which link only core) use it too.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>

namespace palpa {

/// What kind of file a stat mode is, in words ("a FIFO", "a character device", ...).
inline const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISREG(mode)) return "a regular file";
  return "not a regular file";
}

/// Reads the whole of `path` into `bytes`. Returns "" on success, else what is
/// wrong, phrased to follow the file's name: "is not a regular file (a FIFO)",
/// "is 5000 bytes, more than the limit of 100 bytes (LIMIT_NAME)", "cannot be
/// opened for reading (No such file or directory)", "cannot be read (...)".
/// The file is opened non-blocking (a FIFO without a writer does not hang the
/// open), checked with fstat on that descriptor, and read up to its size.
inline std::string read_regular_file(const std::filesystem::path& path, std::uintmax_t max_bytes,
                                     const std::string& limit_name, std::string& bytes) {
  bytes.clear();
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return std::string("cannot be opened for reading (") + std::strerror(errno) + ")";
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    return "cannot be examined (" + why + ")";
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return std::string("is not a regular file (") + file_kind(st.st_mode) + ")";
  }
  const auto size = static_cast<std::uintmax_t>(st.st_size);
  if (size > max_bytes) {
    ::close(fd);
    return "is " + std::to_string(size) + " bytes, more than the limit of " + std::to_string(max_bytes) +
           " bytes (" + limit_name + ")";
  }
  // Read exactly what fstat announced (a file growing meanwhile is cut there).
  bytes.resize(static_cast<std::size_t>(size));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::read(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n < 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      bytes.clear();
      return "cannot be read (" + why + ")";
    }
    if (n == 0) break;  // shrank meanwhile
    done += static_cast<std::size_t>(n);
  }
  bytes.resize(done);
  ::close(fd);
  return "";
}

}  // namespace palpa
