#include "examples/fit/mpi_main.h"

#include <cstdlib>
#include <iostream>
#include <sstream>

#include "autodiff/mpi/mpi_communicator.h"

namespace fit {

bool launched_by_mpirun() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
    if (std::getenv(name)) return true;
  return false;
}

int run_mpi_job(int argc, char** argv, int (*run)(int, char**, const Job&)) {
  gr::MpiSession session(&argc, &argv);
  try {
    gr::MpiCommunicator comm;
    std::ostringstream discarded;  // what a non-root rank would have printed
    Job job{comm.rank() == 0 ? std::cout : discarded, &comm, comm.rank() == 0,
            [&session](const std::string& message) { session.abort(message); }};
    const int code = run(argc, argv, job);
    session.barrier();  // rank 0 has written (or removed) its outputs: now any rank may exit non-zero
    return code;
  } catch (const std::exception& e) {
    session.abort(e.what());
  }
}

}  // namespace fit
