#pragma once
// The loads on the obstacles over time, for wall design
// (docs/output.md#obstacle_forcescsv-the-force-on-each-obstacle): per
// obstacle and component, the impulse of each step, its running total from
// t = 0, and the force averaged over a moving window of output.force_window
// seconds, with the peak of that average. The mean force over one step
// (impulse / h) spikes at an impact by the ratio of the impact's duration to
// h; the impulse and the window average do not depend on the step size.
//
// Every rank holds the same copy (the forces are summed over ranks before
// they come here), so no call communicates.
#include <deque>
#include <string>
#include <vector>

namespace talus {

class ObstacleLoads {
 public:
  // `components` = obstacles x dim values per step, obstacle after obstacle.
  // window: the length T of the moving window, s; 0 for none (the window
  // force is then the step's force).
  ObstacleLoads(int obstacles, int dim, double window);

  // A step from `start` to `end` (h = end - start > 0) whose mean force on
  // the obstacles was `force`: its impulse is force * h. Updates the
  // running total, the window force at `end` and its peak.
  void add_step(double start, double end, const std::vector<double>& force);

  // The last step's impulses, the running totals, the window force at the
  // end of the last step (obstacles x dim each; zeros before any step).
  const std::vector<double>& step_impulse() const { return step_impulse_; }
  const std::vector<double>& total_impulse() const { return total_; }
  const std::vector<double>& window_force() const { return window_force_; }
  // Per obstacle: the largest |window force| so far and the time it was
  // reached (the end of that step; 0 and 0 before any step or without load).
  const std::vector<double>& peak_force() const { return peak_; }
  const std::vector<double>& peak_time() const { return peak_time_; }
  double window() const { return window_; }
  int dim() const { return dim_; }
  int obstacles() const { return obstacles_; }

  // What a checkpoint stores to continue exactly (RunState): the running
  // totals, the peaks, and the steps that still overlap the window, as rows
  // of start, end, then obstacles x dim impulses.
  struct State {
    double window = 0.0;
    std::vector<double> total, peak_force, peak_time, window_steps;
  };
  State state() const;
  // Throws std::invalid_argument with what does not fit this object.
  void restore(const State& state);

 private:
  struct Step {
    double start, end;
    std::vector<double> impulse;
  };
  int obstacles_, dim_;
  double window_;
  std::vector<double> step_impulse_, total_, window_force_, peak_, peak_time_;
  std::deque<Step> steps_;  // the steps with end > t - window, oldest first
};

}  // namespace talus
