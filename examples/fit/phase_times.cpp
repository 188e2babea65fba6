#include "examples/fit/phase_times.h"

namespace fit {

void PhaseTimes::start() { last_ = std::chrono::steady_clock::now(); }

void PhaseTimes::mark(const char* phase) {
  const auto now = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(now - last_).count();
  last_ = now;
  for (PhaseTime& p : phases_)
    if (p.name == phase) {
      p.seconds += seconds;
      return;
    }
  phases_.push_back({phase, seconds});
}

}  // namespace fit
