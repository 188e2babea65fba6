// The processes of an MPI job must run the same fit (issue 30 item 8): ranks
// started with different options (mpirun -np 1 fit --iterations 5 : -np 1 fit
// --iterations 8) would wait forever in a collective the others never reach.
// Before any work, every process publishes its run-shaping options and all of
// them stop, with exit code 2 and a message naming the first option that
// differs, unless every process has the same.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "autodiff/view_gradients.h"
#include "examples/fit/cli.h"

namespace fit {

// (name, value) pairs, in a fixed order.
using OptionList = std::vector<std::pair<std::string, std::string>>;

// What shapes the run, canonical (defaults filled in, so "--iterations 300"
// and no --iterations agree): first ("the command line", "valid" / "--help" /
// "the error '...'"), then every flag but --out (only process 0 writes) and
// --threads (results do not depend on it).
OptionList run_shaping_options(const CommandLine& cl);

// "" if every list equals the first; else a message naming the first entry
// that differs and the first process whose list differs from process 0's.
std::string first_difference(const std::vector<OptionList>& per_process);

// Collective over `comm`: gathers every process's list and returns
// first_difference of them (the same text on every process).
std::string option_disagreement(gr::Communicator& comm, const OptionList& mine);

}  // namespace fit
