#include "autodiff/mpi/mpi_communicator.h"

#include <climits>
#include <cstdlib>
#include <cstdio>

#include "autodiff/base/error.h"

namespace gr {
namespace {

void check(int code, const char* call) {
  if (code != MPI_SUCCESS) throw Error(std::string("MPI: ") + call + " failed with code " + std::to_string(code));
}

}  // namespace

MpiCommunicator::MpiCommunicator(MPI_Comm comm) : comm_(comm) {
  check(MPI_Comm_rank(comm_, &rank_), "MPI_Comm_rank");
  check(MPI_Comm_size(comm_, &size_), "MPI_Comm_size");
}

void MpiCommunicator::all_gather(const std::vector<double>& mine, std::vector<double>& all) {
  if (mine.size() > static_cast<std::size_t>(INT_MAX))
    throw ValueError("MpiCommunicator::all_gather: " + std::to_string(mine.size()) +
                     " values exceed MPI's int count");
  const int count = static_cast<int>(mine.size());
  std::vector<int> counts(static_cast<std::size_t>(size_)), offsets(static_cast<std::size_t>(size_));
  check(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_), "MPI_Allgather");
  long long total = 0;
  for (int r = 0; r < size_; ++r) {
    if (total > INT_MAX) throw ValueError("MpiCommunicator::all_gather: more values in all than MPI's int count");
    offsets[r] = static_cast<int>(total);
    total += counts[r];
  }
  if (total > INT_MAX) throw ValueError("MpiCommunicator::all_gather: more values in all than MPI's int count");
  all.resize(static_cast<std::size_t>(total));
  check(MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE, comm_),
        "MPI_Allgatherv");
}

MpiSession::MpiSession(int* argc, char*** argv) {
  int already = 0;
  MPI_Initialized(&already);
  if (!already) {
    check(MPI_Init(argc, argv), "MPI_Init");
    initialized_here_ = true;
  }
}

MpiSession::~MpiSession() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (initialized_here_ && !finalized) MPI_Finalize();
}

int MpiSession::rank() const {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int MpiSession::size() const {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

void MpiSession::barrier() const { check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier"); }

void MpiSession::abort(const std::string& message, int exit_code) const {
  std::fprintf(stderr, "rank %d of %d: %s\n", rank(), size(), message.c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, exit_code);
  std::abort();  // MPI_Abort does not return; in case it does
}

}  // namespace gr
