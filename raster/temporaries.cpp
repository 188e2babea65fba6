// The registry of temporaries, its signal handler and the stale-temporary
// scan. The handler touches only the fixed table below and makes only
// async-signal-safe calls (open, getdents64, unlink(at), rmdir, close,
// sigaction, raise).
#include "raster/temporaries.h"

#include <dirent.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>

namespace gr::raster {
namespace {

// ---- the table ----

constexpr int kSlots = 128;
enum SlotState : int { kFree = 0, kClaimed = 1, kLive = 2 };

// A seqlock per slot: `version` is odd while the path is being written, so
// the handler, which may run on another thread mid-registration, only acts on
// a path it copied between two equal even versions.
struct Slot {
  std::atomic<int> state{kFree};
  std::atomic<unsigned> version{0};
  TemporaryKind kind = TemporaryKind::File;
  char path[PATH_MAX];
};
Slot g_slots[kSlots];

// ---- removal, async-signal-safe ----

// The kernel's record for getdents64.
struct LinuxDirent64 {
  std::uint64_t ino;
  std::int64_t off;
  unsigned short reclen;
  unsigned char type;
  char name[1];
};

bool is_dot_or_dot_dot(const char* n) { return n[0] == '.' && (n[1] == 0 || (n[1] == '.' && n[2] == 0)); }

// Unlinks every entry of the folder `name` (relative to `parent`) that is not
// a folder, then removes the folder; a folder with sub-folders stays. Never
// follows a symlink. Returns true if the folder is gone.
bool remove_flat_folder_at(int parent, const char* name) {
  const int fd = ::openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return false;
  alignas(8) char buffer[4096];
  // Unlinking while reading may hide entries from the current pass: rescan
  // until a pass removes nothing.
  for (int pass = 0; pass < 64; ++pass) {
    bool removed = false;
    ::lseek(fd, 0, SEEK_SET);
    for (;;) {
      const long n = ::syscall(SYS_getdents64, fd, buffer, sizeof buffer);
      if (n <= 0) break;
      for (long at = 0; at < n;) {
        const auto* d = reinterpret_cast<const LinuxDirent64*>(buffer + at);
        at += d->reclen;
        if (!is_dot_or_dot_dot(d->name) && ::unlinkat(fd, d->name, 0) == 0) removed = true;  // EISDIR for folders
      }
    }
    if (!removed) break;
  }
  ::close(fd);
  return ::unlinkat(parent, name, AT_REMOVEDIR) == 0;
}

bool remove_path(TemporaryKind kind, const char* path) {
  switch (kind) {
    case TemporaryKind::File: return ::unlink(path) == 0;
    case TemporaryKind::Folder: return remove_flat_folder_at(AT_FDCWD, path);
    case TemporaryKind::EmptyFolder: return ::rmdir(path) == 0;
  }
  return false;
}

// Removes every registered path of `kind`; returns how many went.
int remove_registered(TemporaryKind kind) {
  int removed = 0;
  char path[PATH_MAX];
  for (Slot& s : g_slots) {
    if (s.state.load(std::memory_order_acquire) != kLive || s.kind != kind) continue;
    const unsigned before = s.version.load(std::memory_order_acquire);
    if (before & 1u) continue;
    std::memcpy(path, s.path, sizeof path);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (s.version.load(std::memory_order_relaxed) != before) continue;  // re-registered meanwhile
    path[PATH_MAX - 1] = 0;
    removed += remove_path(kind, path);
  }
  return removed;
}

// Files first, then staging folders, then the (now empty) output folders,
// innermost first: repeated while an rmdir succeeds.
void remove_all_registered() {
  remove_registered(TemporaryKind::File);
  remove_registered(TemporaryKind::Folder);
  for (int pass = 0; pass < kSlots && remove_registered(TemporaryKind::EmptyFolder) > 0; ++pass) {
  }
}

constexpr int kSignals[] = {SIGHUP, SIGINT, SIGPIPE, SIGTERM, SIGXCPU, SIGXFSZ};

void on_signal(int sig) {
  remove_all_registered();
  // End the process by the same signal: the default action, delivered as
  // soon as this handler returns (the signal is blocked until then).
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// ---- names ----

// FNV-1a of the host name: two machines (or containers with their own pid
// numbering) writing into one shared folder do not judge each other's pids.
std::uint32_t host_tag() {
  static const std::uint32_t tag = [] {
    char name[HOST_NAME_MAX + 1] = {};
    if (::gethostname(name, sizeof name - 1) != 0) name[0] = 0;
    std::uint32_t h = 2166136261u;
    for (const char* c = name; *c; ++c) h = (h ^ static_cast<unsigned char>(*c)) * 16777619u;
    return h;
  }();
  return tag;
}

std::string name_prefix() {
  char prefix[40];
  std::snprintf(prefix, sizeof prefix, ".gr%lx.%08x.", static_cast<unsigned long>(::getpid()), host_tag());
  return prefix;
}

// Reads 1..max_digits lowercase hex digits at `p`; returns the end or nullptr.
const char* read_hex(const char* p, int max_digits, unsigned long long& value) {
  value = 0;
  int n = 0;
  for (; n < max_digits && ((*p >= '0' && *p <= '9') || (*p >= 'a' && *p <= 'f')); ++p, ++n)
    value = value * 16 + static_cast<unsigned>(*p <= '9' ? *p - '0' : *p - 'a' + 10);
  return n > 0 ? p : nullptr;
}

enum class Leftover { None, File, Folder };

// What `name` is, if it is one of our temporaries made on this host, and by
// which process.
Leftover parse_name(const char* name, pid_t& pid) {
  if (std::strncmp(name, ".gr", 3) != 0) return Leftover::None;
  unsigned long long p = 0, host = 0, counter = 0;
  const char* at = read_hex(name + 3, 16, p);
  if (!at || *at != '.' || p == 0 || p > static_cast<unsigned long long>(INT_MAX)) return Leftover::None;
  const char* host_end = read_hex(at + 1, 8, host);
  if (!host_end || host_end - (at + 1) != 8 || *host_end != '.' || host != host_tag()) return Leftover::None;
  pid = static_cast<pid_t>(p);
  if (std::strcmp(host_end + 1, "staging") == 0) return Leftover::Folder;
  const char* counter_end = read_hex(host_end + 1, 8, counter);
  return counter_end && std::strcmp(counter_end, ".tmp") == 0 ? Leftover::File : Leftover::None;
}

bool process_is_gone(pid_t pid) { return pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH; }

}  // namespace

TemporaryRegistration::TemporaryRegistration(const std::string& path, TemporaryKind kind) {
  std::error_code ec;
  const std::string absolute = std::filesystem::absolute(path, ec).string();
  if (ec || absolute.size() >= PATH_MAX) return;
  for (int i = 0; i < kSlots; ++i) {
    Slot& s = g_slots[i];
    int expected = kFree;
    if (!s.state.compare_exchange_strong(expected, kClaimed, std::memory_order_acq_rel)) continue;
    s.version.fetch_add(1, std::memory_order_acq_rel);  // odd: being written
    s.kind = kind;
    std::memcpy(s.path, absolute.c_str(), absolute.size() + 1);
    s.version.fetch_add(1, std::memory_order_release);  // even again
    s.state.store(kLive, std::memory_order_release);
    slot_ = i;
    return;
  }
}

TemporaryRegistration& TemporaryRegistration::operator=(TemporaryRegistration&& other) noexcept {
  if (this != &other) {
    release();
    slot_ = other.slot_;
    other.slot_ = -1;
  }
  return *this;
}

void TemporaryRegistration::release() {
  if (slot_ < 0) return;
  g_slots[slot_].state.store(kFree, std::memory_order_release);
  slot_ = -1;
}

std::size_t registered_temporaries() {
  std::size_t n = 0;
  for (const Slot& s : g_slots) n += s.state.load(std::memory_order_acquire) == kLive;
  return n;
}

void remove_temporaries_on_signals() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction action {};
    action.sa_handler = on_signal;
    action.sa_flags = SA_RESTART;
    sigemptyset(&action.sa_mask);
    for (int sig : kSignals) sigaddset(&action.sa_mask, sig);  // one cleanup at a time
    for (int sig : kSignals) {
      struct sigaction current {};
      if (::sigaction(sig, nullptr, &current) != 0) continue;
      const bool is_default = !(current.sa_flags & SA_SIGINFO) && current.sa_handler == SIG_DFL;
      if (is_default) ::sigaction(sig, &action, nullptr);
    }
  });
}

std::string temporary_file_name() {
  static std::atomic<unsigned> counter{0};
  char n[16];
  std::snprintf(n, sizeof n, "%x.tmp", counter++);
  return name_prefix() + n;
}

std::string staging_folder_name() { return name_prefix() + "staging"; }

int remove_stale_temporaries(const std::string& folder) {
  const int fd = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return 0;
  DIR* dir = ::fdopendir(fd);
  if (!dir) {
    ::close(fd);
    return 0;
  }
  int removed = 0;
  // Collect first: removing while readdir walks the folder may skip entries.
  std::set<std::string> files, folders;
  while (const dirent* e = ::readdir(dir)) {
    pid_t pid = 0;
    const Leftover kind = parse_name(e->d_name, pid);
    if (kind == Leftover::None || !process_is_gone(pid)) continue;
    (kind == Leftover::File ? files : folders).insert(e->d_name);
  }
  for (const std::string& name : files) {
    struct stat st {};
    if (::fstatat(fd, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode))
      removed += ::unlinkat(fd, name.c_str(), 0) == 0;
  }
  for (const std::string& name : folders) removed += remove_flat_folder_at(fd, name.c_str());  // O_NOFOLLOW
  ::closedir(dir);  // closes fd
  return removed;
}

void remove_stale_temporaries_once(const std::string& folder) {
  static std::mutex mutex;
  static std::set<std::string> scanned;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (!scanned.insert(folder).second) return;
  }
  remove_stale_temporaries(folder);
}

}  // namespace gr::raster
