#pragma once
// What a run prints while it runs (docs/command_line.md#the-progress-line):
// the progress line, and the messages (cut-backs, warnings, checkpoints)
// on lines of their own between its updates.
#include <chrono>
#include <deque>
#include <iosfwd>
#include <limits>
#include <string>
#include <utility>

namespace talus {

struct ProgressOptions {
  // terminal: one line rewritten in place (a carriage return), at most every
  // terminal_seconds; lines: a line at the first step of the run, at every
  // step number (since t = 0) divisible by `every_steps`, after
  // `every_seconds` of wall time without a line (0 turns either off), at
  // every output and at the last step; off (--quiet): no progress line.
  enum class Mode { off, lines, terminal };
  Mode mode = Mode::lines;
  long every_steps = 100;
  double every_seconds = 10.0;
  double terminal_seconds = 0.25;
  int terminal_width = 0;  // columns of the terminal, 0 if unknown (no truncation)
};

// The figures of one progress line.
struct ProgressFigures {
  long step = 0;  // accepted steps since t = 0 (the numbering of checkpoint_<steps>.h5)
  double time = 0, end = 0, h = 0;
  bool explicit_step = false;
  long newton = 0, linear = 0;  // iterations of this step
  double unbalance = 0;
  long active = 0;
  double elapsed = 0;                                     // wall seconds since the run started
  double eta = std::numeric_limits<double>::quiet_NaN();  // wall seconds to time.end, NaN if not known yet
  double max_speed = 0, kinetic = 0, front = 0;           // m/s, J (J/m in 2D), m
  int dim = 2;
  bool output = false;
};

// The text of a progress line: `terminal` the short form for a line
// rewritten in place, else the log form (docs/command_line.md).
std::string progress_text(const ProgressFigures& f, bool terminal);
// hh:mm:ss of a number of seconds; "--:--:--" for NaN.
std::string clock_text(double seconds);
// Wall seconds since t0.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Time to time.end from the simulated-time rate over the last `window`
// seconds of wall time, not from the start of the run: the first step pays
// the set-up, and a landslide's steps grow costlier as it flows.
class EtaEstimate {
 public:
  explicit EtaEstimate(double window = 30.0) : window_(window) {}
  // An accepted step ended at wall second `elapsed`, simulated time `time`.
  void add(double elapsed, double time);
  // Wall seconds to `end` (NaN before two steps).
  double seconds_to(double end) const;

 private:
  double window_;
  std::deque<std::pair<double, double>> samples_;  // (elapsed, time)
};

class ProgressLog {
 public:
  // `out`: where rank 0 prints (nullptr on other ranks, or for no output at all).
  ProgressLog(std::ostream* out, const ProgressOptions& options) : out_(out), options_(options) {}
  ~ProgressLog() { finish(); }
  ProgressLog(const ProgressLog&) = delete;
  ProgressLog& operator=(const ProgressLog&) = delete;

  // Whether the step just accepted, number `step` since t = 0 (`first` of
  // this run, writing an output, reaching time.end), gets a line; meaningful
  // on rank 0, whose clock decides.
  bool wants_line(long step, bool first, bool output, bool last, double elapsed) const;
  void line(const ProgressFigures& figures);
  // A message on a line of its own; on a terminal the progress line is
  // cleared first and drawn again below it.
  void message(const std::string& text);
  // A message that --quiet drops (a checkpoint written).
  void note(const std::string& text);
  // Ends a line drawn in place, before the closing lines of the run.
  void finish();

 private:
  std::ostream* out_;
  ProgressOptions options_;
  double last_elapsed_ = -std::numeric_limits<double>::infinity();
  std::string drawn_;  // the line shown in place on a terminal ("" if none)
};

}  // namespace talus
