#pragma once
// Time-step cut-back and regrowth (docs/solver.md, "Failing steps").
//
// A failed Newton solve halves h. After `patience` successful steps h doubles
// again, up to the nominal step. If a step fails soon after a regrowth (within
// `patience` steps), the grown step was too large for the current phase of
// the flow: the patience doubles (up to max_patience), so a run does not
// retry a step that keeps failing every few steps. Once the nominal step has
// held for 4 x patience steps, the patience relaxes back by halves.
// A step shortened to land on an output time or time.end leaves h as it is:
// the next step is the full step() again.
// A step whose Newton solve was easy (at most easy_iterations iterations)
// counts twice towards the regrowth: the run returns to larger steps as soon
// as Newton shows it has room, not after a fixed count.
#include <algorithm>
#include <limits>

namespace talus {

class StepController {
 public:
  static constexpr long initial_patience = 3, max_patience = 32, easy_iterations = 4;

  explicit StepController(double nominal_step) : nominal_(nominal_step), h_(nominal_step) {}

  double step() const { return h_; }
  double nominal() const { return nominal_; }
  // `time.step: auto` sets the nominal step before every step: a smaller one
  // takes effect at once, a larger one is grown into as after a cut-back.
  void set_nominal(double nominal) {
    nominal_ = nominal;
    h_ = std::min(h_, nominal);
  }
  long patience() const { return patience_; }

  // The complete state, for checkpoints.
  struct State {
    double step;
    long patience, calm, since_growth;
  };
  State state() const { return {h_, patience_, calm_, since_growth_}; }
  // A checkpoint's state; its step is capped at this controller's nominal
  // step (a restart may ask for a smaller time.step).
  void restore(const State& s) {
    h_ = std::min(s.step, nominal_);
    patience_ = s.patience;
    calm_ = s.calm;
    since_growth_ = s.since_growth;
  }

  // The step of size step() failed: halve it. Returns the new step. A step
  // the run had shortened (to land on an output time or time.end) failed at
  // `attempted` < step(): half of that, since a retry at half of step() could
  // be the same shortened step again.
  double failed(double attempted = std::numeric_limits<double>::infinity()) {
    if (since_growth_ <= patience_) patience_ = std::min(2 * patience_, max_patience);
    h_ = 0.5 * std::min(h_, attempted);
    calm_ = 0;
    since_growth_ = patience_ + 1;  // one back-off per regrowth
    return h_;
  }

  // The step of size step() converged, in newton_iterations (< 0: unknown).
  void succeeded(long newton_iterations = -1) {
    ++since_growth_;
    if (h_ < nominal_) {
      calm_ += newton_iterations >= 0 && newton_iterations <= easy_iterations ? 2 : 1;
      if (calm_ >= patience_) {
        h_ = std::min(nominal_, 2.0 * h_);
        calm_ = 0;
        since_growth_ = 0;
      }
    } else if (since_growth_ > 4 * patience_ && patience_ > initial_patience) {
      patience_ = std::max(initial_patience, patience_ / 2);
      since_growth_ = 0;
    }
  }

 private:
  double nominal_, h_;
  long patience_ = initial_patience;
  long calm_ = 0;
  long since_growth_ = 1L << 40;  // no regrowth yet
};

}  // namespace talus
