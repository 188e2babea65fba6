// How gradraster-fit runs: alone, or as one process of an MPI job.
#pragma once

#include <functional>
#include <ostream>
#include <string>

#include "autodiff/view_gradients.h"

namespace fit {

struct Job {
  std::ostream& out;                   // the summary and progress (a null stream off the root)
  gr::Communicator* comm = nullptr;    // the process group; nullptr: this process alone
  bool root = true;                    // prints and writes the outputs
  // Called with the message of a failure before it is reported: in an MPI job
  // it ends every process (MPI_Abort) instead of leaving them waiting.
  std::function<void(const std::string&)> fail;
};

}  // namespace fit
