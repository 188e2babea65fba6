// Temporaries an interrupted run must not leave behind (issue 30, item 6).
//
// Every temporary gradraster writes is registered here while it exists:
// OutputSet's files ".gr<pid>.<host>.<n>.tmp", gradraster-fit's staging folder
// ".gr<pid>.<host>.staging" and the output folders a failed run removes (pid
// and n in hex, host: 8 hex digits naming this machine). They go away when a
// run does not end normally in one of two ways:
//  - a termination signal (SIGINT, SIGTERM, SIGHUP, SIGPIPE, SIGXCPU,
//    SIGXFSZ) in a program that called remove_temporaries_on_signals() (every
//    tool does): the handler removes each registered path (async-signal-safe:
//    a fixed table, unlink and rmdir only) and ends the process by the same
//    signal with its default action, so the exit status still names it;
//  - SIGKILL, a crash or a power cut: the next run writing into the same
//    folder removes them (remove_stale_temporaries): only names matching the
//    patterns above exactly, made on this host by a process that no longer
//    exists (kill(pid, 0) fails with ESRCH).
#pragma once

#include <cstddef>
#include <string>

namespace gr::raster {

// How the signal handler removes a registered path.
enum class TemporaryKind {
  File,         // unlink
  Folder,       // the entries of a flat folder (not sub-folders), then the folder
  EmptyFolder,  // rmdir: removed only if empty (a folder a run created for its outputs)
};

// Registers `path` (made absolute) while the object lives; the destructor
// only unregisters, it removes nothing. The table has a fixed size: a path
// beyond it (or longer than PATH_MAX) is not registered, and only
// remove_stale_temporaries will find it.
class TemporaryRegistration {
 public:
  TemporaryRegistration() = default;
  TemporaryRegistration(const std::string& path, TemporaryKind kind);
  ~TemporaryRegistration() { release(); }
  TemporaryRegistration(TemporaryRegistration&& other) noexcept : slot_(other.slot_) { other.slot_ = -1; }
  TemporaryRegistration& operator=(TemporaryRegistration&& other) noexcept;
  TemporaryRegistration(const TemporaryRegistration&) = delete;
  TemporaryRegistration& operator=(const TemporaryRegistration&) = delete;
  void release();  // unregisters now

 private:
  int slot_ = -1;
};

// How many paths are registered now (for tests: a finished write leaves none).
std::size_t registered_temporaries();

// Installs the cleanup handler for the signals above; call it once, early in
// main(). A signal whose action is not the default one (ignored, e.g. SIGINT
// of a background job, or handled by someone else) is left alone.
void remove_temporaries_on_signals();

// A new temporary file name ".gr<pid>.<host>.<n>.tmp" (no folder), unique in
// this process.
std::string temporary_file_name();
// This process's staging folder name ".gr<pid>.<host>.staging" (no folder).
std::string staging_folder_name();

// Removes from `folder` (not its sub-folders) the temporary files and staging
// folders left by dead processes of this host (see above); a name that does
// not match exactly, a symlink, a live or foreign process's temporary, and
// anything else are left alone. Returns how many were removed. Never throws.
int remove_stale_temporaries(const std::string& folder);
// The same, at most once per folder name in this process (writers call it
// before every write; the scan reads the whole folder).
void remove_stale_temporaries_once(const std::string& folder);

}  // namespace gr::raster
