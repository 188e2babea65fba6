// Input reading and output sets over POSIX calls: open + fstat for inputs (the
// descriptor that is read is the one that was checked), lstat + O_EXCL |
// O_NOFOLLOW temporaries + fsync + rename for outputs.
#include "raster/io/files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "raster/temporaries.h"

namespace gr::raster {
namespace {

std::string errno_text(int e) { return std::strerror(e); }

// Closes a descriptor on scope exit.
struct Fd {
  int fd;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

std::string file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISLNK(mode)) return "a symbolic link";
  return "not a regular file";
}

std::string folder_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

// A short name in `folder` no other writer (thread or process) uses; short so
// that a target whose own name is at the 255-byte limit still works.
std::string temporary_in(const std::string& folder) {
  return (folder == "/" ? "" : folder) + "/" + temporary_file_name();
}

// Writes all bytes to fd and flushes them to disk; returns 0 or an errno.
int write_all(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t k = ::write(fd, p, n);
    if (k < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    p += k, n -= static_cast<std::size_t>(k);
  }
  return ::fsync(fd) == 0 ? 0 : errno;
}

}  // namespace

std::string read_input_file(const std::string& path, const std::string& what, std::size_t limit) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below.
  Fd file{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (file.fd < 0) {
    const int e = errno;
    throw IOError(what + ": cannot open file (" + errno_text(e) + ")");
  }
  struct stat st {};
  if (::fstat(file.fd, &st) != 0) throw IOError(what + ": cannot stat file (" + errno_text(errno) + ")");
  if (S_ISDIR(st.st_mode)) throw IOError(what + ": is a directory");
  if (!S_ISREG(st.st_mode))
    throw IOError(what + ": is " + file_kind(st.st_mode) + ", not a regular file");
  const auto size = static_cast<std::size_t>(st.st_size);
  const std::string too_large = what + ": file is larger than the input limit of " +
                                std::to_string(limit) + " bytes";
  if (size > limit) throw IOError(too_large + " (" + std::to_string(size) + " bytes)");
  check_memory_request(size, what);

  // Read to the end: a file can be longer than fstat said (/proc files report 0).
  std::string text(size, '\0');
  std::size_t got = 0;
  for (;;) {
    if (got == text.size()) {
      if (got > limit) throw IOError(too_large);
      const std::size_t more = std::min<std::size_t>(limit + 1 - got, std::max<std::size_t>(got, 4096));
      check_memory_request(more, what);
      text.resize(got + more);
    }
    const ssize_t k = ::read(file.fd, text.data() + got, text.size() - got);
    if (k < 0) {
      if (errno == EINTR) continue;
      throw IOError(what + ": read error (" + errno_text(errno) + ")");
    }
    if (k == 0) break;
    got += static_cast<std::size_t>(k);
  }
  if (got > limit) throw IOError(too_large);
  text.resize(got);
  return text;
}

void check_output_target(const std::string& path) {
  if (path.empty()) throw IOError("cannot write an output with an empty path");
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return;
    throw IOError("cannot write '" + path + "': " + errno_text(errno));
  }
  if (!S_ISREG(st.st_mode))
    throw IOError("cannot write '" + path + "': it exists and is " + file_kind(st.st_mode) +
                  "; refusing to replace anything but a regular file");
}

OutputSet::~OutputSet() {
  for (const Staged& s : staged_) ::unlink(s.temporary.c_str());
}

void OutputSet::stage(const std::string& path, const void* data, std::size_t bytes) {
  check_output_target(path);
  const std::string folder = folder_of(path);
  remove_stale_temporaries_once(folder);  // what interrupted runs left here
  const std::string tmp = temporary_in(folder);
  // Registered before it exists: a signal from here on removes it.
  TemporaryRegistration registration(tmp, TemporaryKind::File);
  Fd file{::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666)};
  if (file.fd < 0) throw IOError("cannot write '" + path + "': " + errno_text(errno));
  staged_.push_back({path, tmp, std::move(registration)});  // from here on the destructor removes it
  int e = write_all(file.fd, static_cast<const char*>(data), bytes);
  const int closed = ::close(file.fd);
  file.fd = -1;
  if (e == 0 && closed != 0) e = errno;
  if (e != 0) throw IOError("cannot write '" + path + "': " + errno_text(e));
}

void OutputSet::commit() {
  for (const Staged& s : staged_) check_output_target(s.target);
  while (!staged_.empty()) {
    const Staged& s = staged_.front();
    if (::rename(s.temporary.c_str(), s.target.c_str()) != 0)
      throw IOError("cannot write '" + s.target + "': rename failed: " + errno_text(errno));
    staged_.erase(staged_.begin());
  }
}

std::string quote_for_message(const std::string& text) {
  constexpr std::size_t kShown = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < text.size() && i < kShown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  if (text.size() > kShown) out += "...";
  return out + "'";
}

}  // namespace gr::raster
