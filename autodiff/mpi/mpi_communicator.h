// gr::Communicator over MPI (optional target gradraster::mpi, built when CMake
// finds MPI): ViewGradients' gather as MPI_Allgather + MPI_Allgatherv.
#pragma once

#include <mpi.h>

#include <string>
#include <vector>

#include "autodiff/view_gradients.h"

namespace gr {

class MpiCommunicator : public Communicator {
 public:
  explicit MpiCommunicator(MPI_Comm comm = MPI_COMM_WORLD);
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void all_gather(const std::vector<double>& mine, std::vector<double>& all) override;

 private:
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
};

// MPI_Init on construction, MPI_Finalize on destruction (when it initialized).
// A failure on one process must end the whole job: abort() prints
// "rank R: message" to stderr and calls MPI_Abort, which stops every process
// within seconds instead of leaving the others waiting in a collective.
class MpiSession {
 public:
  MpiSession(int* argc, char*** argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const;
  int size() const;
  // Waits for every process (e.g. until the one writing outputs is done, so
  // that a non-zero exit elsewhere does not make mpirun kill it midway).
  void barrier() const;
  [[noreturn]] void abort(const std::string& message, int exit_code = 1) const;

 private:
  bool initialized_here_ = false;
};

}  // namespace gr
