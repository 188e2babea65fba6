// Where the optimization loop's time goes: wall time summed per named phase
// (gradraster-fit --profile prints it per iteration; docs/performance.md).
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace fit {

struct PhaseTime {
  std::string name;
  double seconds = 0;  // summed over the loop
};

class PhaseTimes {
 public:
  // Starts the clock (the next mark() measures from here).
  void start();
  // Adds the time since the last start() or mark() to `phase` (created at its first mark, in that order).
  void mark(const char* phase);
  const std::vector<PhaseTime>& phases() const { return phases_; }

 private:
  std::chrono::steady_clock::time_point last_;
  std::vector<PhaseTime> phases_;
};

}  // namespace fit
