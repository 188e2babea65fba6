// Peak resident memory of a piece of work, measured in a child process:
// fork(), run `work` in the child only, and read the child's ru_maxrss
// through wait4(). Call it before the parent starts any threads or allocates
// large buffers: the child inherits (and is charged for) whatever the parent
// has resident at the fork.
#pragma once

#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <stdexcept>

namespace gr::bench {

// Peak RSS of the child in KiB (Linux ru_maxrss unit). Throws if the child fails.
inline long child_peak_rss_kib(const std::function<void()>& work) {
  std::fflush(nullptr);  // do not let the child flush the parent's buffered output
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    int code = 0;
    try {
      work();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "child: %s\n", e.what());
      code = 1;
    }
    std::fflush(nullptr);
    _exit(code);  // skip the parent's atexit handlers and static destructors
  }
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("peak-RSS child process failed");
  return usage.ru_maxrss;
}

}  // namespace gr::bench
