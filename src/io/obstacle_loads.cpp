#include "talus/io/obstacle_loads.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace talus {

ObstacleLoads::ObstacleLoads(int obstacles, int dim, double window)
    : obstacles_(obstacles), dim_(dim), window_(window) {
  const std::size_t n = static_cast<std::size_t>(obstacles) * dim;
  step_impulse_.assign(n, 0.0);
  total_.assign(n, 0.0);
  window_force_.assign(n, 0.0);
  peak_.assign(obstacles, 0.0);
  peak_time_.assign(obstacles, 0.0);
}

void ObstacleLoads::add_step(double start, double end, const std::vector<double>& force) {
  const std::size_t n = total_.size();
  if (force.size() != n) throw std::invalid_argument("ObstacleLoads: a force row of the wrong length");
  // h from the times themselves (what the table's time column gives back),
  // so that consecutive steps tile the time axis without gap or overlap.
  const double h = end - start;
  for (std::size_t k = 0; k < n; ++k) {
    step_impulse_[k] = force[k] * h;
    total_[k] += step_impulse_[k];
  }
  if (window_ > 0.0) {
    // The window (end - T, end]. A step that ended at or before its start is
    // never needed again (the window only moves forward).
    const double lower = end - window_;
    steps_.push_back({start, end, step_impulse_});
    while (!steps_.empty() && steps_.front().end <= lower) steps_.pop_front();
    if (lower <= 0.0) {
      // Before a full window every step since t = 0 is inside: the mean since t = 0.
      for (std::size_t k = 0; k < n; ++k) window_force_[k] = total_[k] / end;
    } else if (start <= lower) {
      window_force_ = force;  // the window lies within this step (T <= h): its force
    } else {
      // The mean of the piecewise-constant step force over the window: whole
      // steps by their impulse, the step that straddles the window's start
      // by the part inside it. Summed oldest first, from the stored impulses
      // alone, so that a restart from the stored steps repeats the sum exactly.
      std::fill(window_force_.begin(), window_force_.end(), 0.0);
      for (const Step& s : steps_) {
        const double part = s.start >= lower ? 1.0 : (s.end - lower) / (s.end - s.start);
        for (std::size_t k = 0; k < n; ++k) window_force_[k] += part * s.impulse[k];
      }
      for (double& f : window_force_) f /= window_;
    }
  } else {
    window_force_ = force;  // the limit T -> 0 of the window mean: the step's force
  }
  for (int o = 0; o < obstacles_; ++o) {
    double squared = 0.0;
    for (int a = 0; a < dim_; ++a) squared += window_force_[o * dim_ + a] * window_force_[o * dim_ + a];
    const double magnitude = std::sqrt(squared);
    if (magnitude > peak_[o]) {  // strictly: the first time a peak is reached
      peak_[o] = magnitude;
      peak_time_[o] = end;
    }
  }
}

ObstacleLoads::State ObstacleLoads::state() const {
  State s;
  s.window = window_;
  s.total = total_;
  s.peak_force = peak_;
  s.peak_time = peak_time_;
  for (const Step& step : steps_) {
    s.window_steps.push_back(step.start);
    s.window_steps.push_back(step.end);
    s.window_steps.insert(s.window_steps.end(), step.impulse.begin(), step.impulse.end());
  }
  return s;
}

void ObstacleLoads::restore(const State& s) {
  const std::size_t n = total_.size(), row = 2 + n;
  if (s.window != window_)
    throw std::invalid_argument("ObstacleLoads: the stored window differs from this run's");
  if (s.total.size() != n || s.peak_force.size() != peak_.size() || s.peak_time.size() != peak_.size() ||
      s.window_steps.size() % row != 0)
    throw std::invalid_argument("ObstacleLoads: stored loads of another number of obstacles or components");
  total_ = s.total;
  peak_ = s.peak_force;
  peak_time_ = s.peak_time;
  steps_.clear();
  for (std::size_t r = 0; r < s.window_steps.size(); r += row)
    steps_.push_back({s.window_steps[r], s.window_steps[r + 1],
                      std::vector<double>(s.window_steps.begin() + r + 2, s.window_steps.begin() + r + row)});
  std::fill(step_impulse_.begin(), step_impulse_.end(), 0.0);
  std::fill(window_force_.begin(), window_force_.end(), 0.0);
}

}  // namespace talus
