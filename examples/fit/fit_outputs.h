// run_fit as a tool run: its memory estimate checked first, and its outputs
// (snapshots, loss plot, fitted OBJ, ...) appearing in options.out_dir all
// together or not at all. gradraster-fit's main() calls it.
#pragma once

#include <cstddef>
#include <ostream>

#include "examples/fit/fit.h"

namespace fit {

// Memory a fit needs, measured on gradraster-fit: peak RSS grows by ~275 bytes
// per pixel and view (G-buffers, shading, antialias, their gradients and
// saved values), over a base of a few MB.
std::size_t fit_request_bytes(const FitOptions& options);

// Checks fit_request_bytes against the memory budget (MemoryError), runs
// run_fit into a staging folder inside options.out_dir and, when it
// succeeded, moves every file into options.out_dir (refusing targets that are
// not regular files). A failed run removes the staging folder and the output
// folder if this call created it; std::bad_alloc becomes a gr::MemoryError.
// FitResult::files name the final paths.
FitResult run_fit_with_outputs(const FitOptions& options, std::ostream& log);

}  // namespace fit
