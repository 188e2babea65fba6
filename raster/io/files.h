// Safe file access for every gradraster reader and writer.
//
// Inputs (OBJ, MTL, images): read_input_file opens the path (a symlink to a
// regular file is followed, as users expect), refuses anything that is not a
// regular file (folder, FIFO, device, socket) without blocking on it, and reads
// at most a size limit, so /dev/zero, a pipe or a growing /proc file fail with
// an IOError naming the path instead of hanging or exhausting memory.
//
// Outputs: an OutputSet writes each file of a run to a temporary in the
// target's folder and renames them all into place only in commit(), so a run's
// outputs appear together or not at all. A target that exists and is not a
// regular file (symlink, FIFO, device, folder) is refused and left untouched.
// An interrupted run leaves no temporary behind (raster/temporaries.h).
//
//   raster::OutputSet outputs;
//   outputs.stage("a.png", png.data(), png.size());    // IOError: nothing renamed
//   outputs.stage("a.raw", raw.data(), raw.size());
//   outputs.commit();                                  // both appear
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "raster/temporaries.h"

namespace gr::raster {

// The largest input file any reader accepts (1 GiB); read_input_file also
// checks the size against the memory budget (autodiff/base/memory.h).
constexpr std::size_t kMaxInputFileBytes = std::size_t(1) << 30;

// Reads the whole regular file `path`. Throws IOError whose message starts
// with `what` and names the problem: missing or unreadable, a folder, not a
// regular file (FIFO, device, socket), larger than `limit` bytes; MemoryError
// if the bytes would exceed the memory budget.
std::string read_input_file(const std::string& path, const std::string& what,
                            std::size_t limit = kMaxInputFileBytes);

// Throws IOError naming `path` if it exists and is not a regular file (a
// symlink is refused, not followed), or if it is empty. Writers call it before
// doing any work, so a bad target fails early.
void check_output_target(const std::string& path);

// A set of output files written all together or not at all (see above).
class OutputSet {
 public:
  OutputSet() = default;
  ~OutputSet();  // removes temporaries not committed
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // Checks `path` (check_output_target) and writes `bytes` to a new temporary
  // next to it (O_EXCL | O_NOFOLLOW, flushed to disk). Throws IOError naming
  // `path`; the set's temporaries are then removed by the destructor.
  void stage(const std::string& path, const void* data, std::size_t bytes);
  // Renames every staged temporary over its target, after checking every
  // target again. Throws IOError naming the target that failed.
  void commit();

 private:
  struct Staged {
    std::string target, temporary;
    TemporaryRegistration registration;  // removed by a signal (raster/temporaries.h)
  };
  std::vector<Staged> staged_;
};

// Quotes `text` for an error message: at most 40 bytes (then "..."), control
// and non-ASCII bytes written as \xNN, so a huge or binary token stays short
// and printable: 'abc\x00...'.
std::string quote_for_message(const std::string& text);

}  // namespace gr::raster
