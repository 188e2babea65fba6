#include "examples/fit/snapshot_writer.h"

#include <utility>

#ifdef __linux__
#include <pthread.h>
#include <sched.h>
#endif

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "examples/fit/snapshot.h"

namespace fit {

SnapshotWriter::~SnapshotWriter() { stop(); }

void SnapshotWriter::write(std::string path, std::vector<gr::Tensor> targets, std::vector<gr::Tensor> currents) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (failure_) return;  // finish() reports it
  queue_.push_back({std::move(path), std::move(targets), std::move(currents)});
  if (!thread_.joinable()) thread_ = std::thread([this] { work(); });
  changed_.notify_all();
}

void SnapshotWriter::finish() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return (queue_.empty() && !busy_) || failure_; });
  if (failure_) std::rethrow_exception(failure_);
}

void SnapshotWriter::work() {
#ifdef __linux__
  // Idle priority: the writer takes only CPU time the optimization leaves
  // (on one thread, a whole core; on all of them, the pauses and the end of
  // the loop), never slowing it down. finish() waits for it either way.
  sched_param idle{};
  pthread_setschedparam(pthread_self(), SCHED_IDLE, &idle);
#endif
  gr::SerialScope serial;    // and on this thread alone: the workers' slots belong to the loop
  gr::NoGradGuard no_grad;  // the strip is made of tensor ops: nothing to record
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return !queue_.empty() || stopping_; });
    if (stopping_) return;
    Job job = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    std::exception_ptr failure;
    try {
      write_snapshot(job.path, job.targets, job.currents);
    } catch (...) {
      failure = std::current_exception();
    }
    lock.lock();
    busy_ = false;
    if (failure && !failure_) {
      failure_ = failure;
      queue_.clear();
    }
    changed_.notify_all();
  }
}

void SnapshotWriter::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    changed_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

}  // namespace fit
