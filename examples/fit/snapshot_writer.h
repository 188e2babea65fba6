// Writes snapshot strips on a thread of its own, at idle priority, so
// composing and encoding them (about 20 ms of CPU for 6 views at 256x256,
// serial: raster/io/png_encoder.h) uses the CPU time the optimization loop leaves
// instead of stalling it. The files are the same bytes as
// write_snapshot's, each appears whole (raster::write_png writes a temporary
// and renames it), and they are all on disk when finish() returns.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "autodiff/base/tensor.h"

namespace fit {

class SnapshotWriter {
 public:
  SnapshotWriter() = default;
  // Waits for the snapshot being written, drops the queued ones (a run that
  // ends this way failed; its staged outputs are discarded anyway).
  ~SnapshotWriter();
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // Queues write_snapshot(path, targets, currents) and returns. The images
  // are read later, on the writer's thread: nothing may write into them.
  void write(std::string path, std::vector<gr::Tensor> targets, std::vector<gr::Tensor> currents);
  // Waits until every queued snapshot is written; rethrows the first failure.
  void finish();

 private:
  struct Job {
    std::string path;
    std::vector<gr::Tensor> targets, currents;
  };
  void work();
  void stop();

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Job> queue_;
  bool busy_ = false, stopping_ = false;
  std::exception_ptr failure_;
  std::thread thread_;  // started by the first write()
};

}  // namespace fit
