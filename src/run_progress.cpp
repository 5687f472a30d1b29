#include "talus/run_progress.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <ostream>
#include <sstream>

namespace talus {

std::string clock_text(double s) {
  if (!std::isfinite(s)) return "--:--:--";
  const long t = std::lround(std::max(0.0, s));
  std::ostringstream os;
  os << std::setfill('0') << std::setw(2) << t / 3600 << ":" << std::setw(2) << (t / 60) % 60 << ":" << std::setw(2)
     << t % 60;
  return os.str();
}

std::string progress_text(const ProgressFigures& f, bool terminal) {
  std::ostringstream os;
  const char* energy_unit = f.dim == 2 ? " J/m" : " J";  // 2D: per metre of thickness
  if (terminal) {
    // Short enough for a terminal of about 110 columns; the log form has the solver's figures.
    const double percent = f.end > 0 ? 100.0 * f.time / f.end : 100.0;
    os << "step " << f.step << "  t " << std::setprecision(4) << f.time << " s (" << std::fixed
       << std::setprecision(0) << std::floor(percent) << "%)" << std::defaultfloat << "  h " << std::scientific
       << std::setprecision(1) << f.h << std::defaultfloat << "  elapsed " << clock_text(f.elapsed) << "  ETA "
       << clock_text(f.eta) << std::setprecision(3) << "  v_max " << f.max_speed << " m/s  KE " << f.kinetic
       << energy_unit << std::setprecision(4) << "  front " << f.front << " m";
    return os.str();
  }
  os << "step " << std::setw(f.explicit_step ? 7 : 6) << f.step << "  t " << std::scientific << std::setprecision(4)
     << f.time << "  h " << std::setprecision(3) << f.h << std::defaultfloat;
  if (f.explicit_step)
    os << "  explicit";
  else
    os << "  newton " << f.newton << "  ksp " << f.linear << "  unbalance " << std::scientific << std::setprecision(1)
       << f.unbalance << std::defaultfloat;
  os << "  active " << f.active << "  elapsed " << clock_text(f.elapsed) << "  ETA " << clock_text(f.eta)
     << std::setprecision(6) << "  v_max " << f.max_speed << " m/s  KE " << f.kinetic << energy_unit << "  front "
     << f.front << " m" << (f.output ? "  [output]" : "");
  return os.str();
}

void EtaEstimate::add(double elapsed, double time) {
  samples_.emplace_back(elapsed, time);
  // Keep one sample at or before the window's start, so the rate spans it.
  while (samples_.size() > 2 && samples_[1].first <= elapsed - window_) samples_.pop_front();
}

double EtaEstimate::seconds_to(double end) const {
  if (samples_.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  const auto& [w0, t0] = samples_.front();
  const auto& [w1, t1] = samples_.back();
  if (!(t1 > t0)) return std::numeric_limits<double>::quiet_NaN();
  return std::max(0.0, end - t1) * (w1 - w0) / (t1 - t0);
}

bool ProgressLog::wants_line(long step, bool first, bool output, bool last, double elapsed) const {
  switch (options_.mode) {
    case ProgressOptions::Mode::off:
      return false;
    case ProgressOptions::Mode::terminal:
      return first || last || elapsed - last_elapsed_ >= options_.terminal_seconds;
    case ProgressOptions::Mode::lines:
      break;
  }
  return first || output || last || (options_.every_steps > 0 && step % options_.every_steps == 0) ||
         (options_.every_seconds > 0 && elapsed - last_elapsed_ >= options_.every_seconds);
}

void ProgressLog::line(const ProgressFigures& figures) {
  last_elapsed_ = figures.elapsed;
  if (!out_ || options_.mode == ProgressOptions::Mode::off) return;
  if (options_.mode == ProgressOptions::Mode::terminal) {
    drawn_ = progress_text(figures, true);
    if (options_.terminal_width > 1 && drawn_.size() >= static_cast<std::size_t>(options_.terminal_width))
      drawn_.resize(options_.terminal_width - 1);  // a wrapped line could not be rewritten in place
    *out_ << '\r' << drawn_ << "\033[K" << std::flush;
    return;
  }
  *out_ << progress_text(figures, false) << "\n" << std::flush;
}

void ProgressLog::message(const std::string& text) {
  if (!out_) return;
  if (!drawn_.empty()) *out_ << "\r\033[K";
  *out_ << text << "\n";
  if (!drawn_.empty()) *out_ << '\r' << drawn_;
  *out_ << std::flush;
}

void ProgressLog::note(const std::string& text) {
  if (options_.mode != ProgressOptions::Mode::off) message(text);
}

void ProgressLog::finish() {
  if (out_ && !drawn_.empty()) *out_ << "\n" << std::flush;
  drawn_.clear();
}

}  // namespace talus
