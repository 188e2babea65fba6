// ProgressBar: '\r'-redrawn bar on a terminal, periodic plain lines otherwise.
#include "examples/fit/progress.h"

#include <unistd.h>

#include <cstdio>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <string>

namespace fit {

bool stdout_is_terminal() { return isatty(fileno(stdout)) != 0; }

ProgressBar::ProgressBar(int total_iterations, std::ostream& out, bool interactive)
    : total_(total_iterations > 0 ? total_iterations : 1),
      out_(out),
      interactive_(interactive),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

void ProgressBar::update(int done, double loss) {
  const auto now = std::chrono::steady_clock::now();
  if (interactive_) {
    if (done == total_ || !drawn_ || now - last_draw_ >= std::chrono::milliseconds(100)) draw(done, loss);
  } else {
    const int every = total_ >= 10 ? total_ / 10 : 1;
    if (done % every == 0 || done == total_) draw(done, loss);
  }
}

void ProgressBar::draw(int done, double loss) {
  last_draw_ = std::chrono::steady_clock::now();
  drawn_ = true;
  const double seconds = std::chrono::duration<double>(last_draw_ - start_).count();
  const double rate = seconds > 0 ? done / seconds : 0.0;
  const int width = 30, filled = width * done / total_;
  std::ostringstream line;
  if (interactive_) line << '\r';
  line << "[" << std::string(filled, '#') << std::string(width - filled, '.') << "] " << std::setw(5) << done << "/"
       << total_ << "  loss " << std::scientific << std::setprecision(3) << loss << "  " << std::fixed
       << std::setprecision(1) << rate << " it/s";
  out_ << line.str() << (interactive_ ? "" : "\n") << std::flush;
}

void ProgressBar::finish() {
  if (interactive_ && drawn_) out_ << "\n" << std::flush;
  drawn_ = false;
}

}  // namespace fit
