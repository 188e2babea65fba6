// A program run as a child process, for tests that need a real process:
// signals, exit statuses, resource limits. Its stdout and stderr go to one
// pipe the test reads; a child still running when the object goes out of
// scope is killed (SIGKILL) and reaped.
//
//   gr::testing::ChildProcess child({program, "--out", dir});
//   REQUIRE(child.wait_for_output("staged", 10));
//   ::kill(child.pid(), SIGTERM);
//   const int status = child.wait(10);   // a waitpid status, -1 on timeout
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace gr::testing {

class ChildProcess {
 public:
  // file_size_limit: RLIMIT_FSIZE of the child (a write past it raises SIGXFSZ).
  explicit ChildProcess(const std::vector<std::string>& args, rlim_t file_size_limit = RLIM_INFINITY) {
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {  // the child: only async-signal-safe calls until exec
      ::dup2(fds[1], 1);
      ::dup2(fds[1], 2);
      const rlimit no_core{0, 0}, size{file_size_limit, file_size_limit};
      ::setrlimit(RLIMIT_CORE, &no_core);
      ::setrlimit(RLIMIT_FSIZE, &size);
      // Default signal actions, none blocked, as a shell starts a foreground
      // job (the test runner may have ignored SIGINT).
      for (int sig : {SIGHUP, SIGINT, SIGPIPE, SIGTERM, SIGXCPU, SIGXFSZ}) ::signal(sig, SIG_DFL);
      sigset_t none;
      sigemptyset(&none);
      ::sigprocmask(SIG_SETMASK, &none, nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(fds[1]);
    out_ = fds[0];
  }
  ~ChildProcess() {
    if (pid_ > 0 && !reaped_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (out_ >= 0) ::close(out_);
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool started() const { return pid_ > 0; }
  // Everything the child printed so far.
  const std::string& output() const { return output_; }

  // Reads the child's output until it contains `text`; false after `seconds`
  // or when the child closed its output without printing it.
  bool wait_for_output(const std::string& text, double seconds) {
    const auto end = deadline(seconds);
    while (output_.find(text) == std::string::npos) {
      if (!read_some(end)) return false;
    }
    return true;
  }

  // Polls `done` every 10 ms for up to `seconds` (reading output meanwhile).
  template <class Predicate>
  bool wait_until(Predicate done, double seconds) {
    const auto end = deadline(seconds);
    while (!done()) {
      if (std::chrono::steady_clock::now() > end) return false;
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  }

  // Waits for the child to end; its waitpid status, or -1 if it still runs
  // after `seconds` (it is then killed).
  int wait(double seconds) {
    const auto end = deadline(seconds);
    for (;;) {
      int status = 0;
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        reaped_ = true;
        drain();
        return status;
      }
      if (r < 0 || std::chrono::steady_clock::now() > end) return -1;
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }

 private:
  static std::chrono::steady_clock::time_point deadline(double seconds) {
    return std::chrono::steady_clock::now() +
           std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
  }
  // Reads what is there without blocking.
  void drain() {
    pollfd p{out_, POLLIN, 0};
    while (out_ >= 0 && ::poll(&p, 1, 0) > 0 && append() > 0) {
    }
  }
  // Waits for output until `end`; false at end of output or on timeout.
  bool read_some(std::chrono::steady_clock::time_point end) {
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      pollfd p{out_, POLLIN, 0};
      const int r = ::poll(&p, 1, static_cast<int>(left.count()));
      if (r > 0) return append() > 0;
      if (r < 0 && errno != EINTR) return false;
    }
  }
  ssize_t append() {
    char buffer[4096];
    const ssize_t n = ::read(out_, buffer, sizeof buffer);
    if (n > 0) output_.append(buffer, static_cast<std::size_t>(n));
    return n;
  }

  pid_t pid_ = -1;
  int out_ = -1;
  bool reaped_ = false;
  std::string output_;
};

// "exited with N", "killed by signal N" or "still running", for messages.
inline std::string describe_status(int status) {
  if (status == -1) return "still running (killed after the timeout)";
  if (WIFEXITED(status)) return "exited with " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  return "status " + std::to_string(status);
}

}  // namespace gr::testing
