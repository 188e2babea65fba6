// A one-line progress bar for optimization loops: iteration, loss and
// iterations per second. On a terminal it redraws one line with '\r' (at most
// ten times a second); otherwise it prints a plain line every tenth of the run.
#pragma once

#include <chrono>
#include <iosfwd>

namespace fit {

// True if standard output is a terminal.
bool stdout_is_terminal();

class ProgressBar {
 public:
  ProgressBar(int total_iterations, std::ostream& out, bool interactive);
  // Call after each iteration; `done` iterations have finished.
  void update(int done, double loss);
  // Ends the line of an interactive bar.
  void finish();

 private:
  void draw(int done, double loss);
  int total_;
  std::ostream& out_;
  bool interactive_;
  std::chrono::steady_clock::time_point start_, last_draw_;
  bool drawn_ = false;
};

}  // namespace fit
