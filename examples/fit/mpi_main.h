// gradraster-fit under mpirun (built when CMake finds MPI): the views are
// split over the processes, every process takes the same optimizer steps
// (autodiff/view_gradients.h), rank 0 prints and writes (docs/scaling.md).
#pragma once

#include "examples/fit/job.h"

namespace fit {

// True when this process was started by mpirun / mpiexec (Open MPI, MPICH
// and PMIx set their variables); a plain start never initializes MPI.
bool launched_by_mpirun();

// Initializes MPI, runs run(argc, argv, job) as this rank's job and finalizes.
// A failure on any rank prints "rank R of P: message" and aborts the job.
int run_mpi_job(int argc, char** argv, int (*run)(int, char**, const Job&));

}  // namespace fit
