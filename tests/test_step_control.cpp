// The cut-back / regrowth controller against a synthetic stiff phase: every
// step larger than h_crit fails while the phase lasts, then all steps pass.
#include <catch2/catch.hpp>

#include "talus/solver/step_control.hpp"

using namespace talus;

namespace {
struct Outcome {
  long steps = 0, failures = 0, failures_in_second_half = 0;
  long steps_to_nominal_after_phase = -1;
};

// Runs `total` accepted steps; steps larger than h_crit fail during the first
// `phase` accepted steps.
Outcome drive(double h_crit, long phase, long total) {
  StepController control(1.0);
  Outcome o;
  while (o.steps < total) {
    const bool stiff = o.steps < phase;
    if (stiff && control.step() > h_crit) {
      ++o.failures;
      if (o.steps >= phase / 2) ++o.failures_in_second_half;
      control.failed();
      continue;
    }
    control.succeeded();
    ++o.steps;
    if (!stiff && o.steps_to_nominal_after_phase < 0 && control.step() == 1.0)
      o.steps_to_nominal_after_phase = o.steps - phase;
  }
  return o;
}
}  // namespace

TEST_CASE("step control: a step that keeps failing is not retried every few steps", "[solver]") {
  // h_crit = 0.3: the largest step that passes is 0.25. A fixed patience of 3
  // would retry 0.5 every 3 steps: 1000 / 4 = 250 failures in 1000 steps.
  const Outcome o = drive(0.3, 1000, 1500);
  INFO("failures " << o.failures << ", in the second half " << o.failures_in_second_half);
  // Patience doubles 3 -> 32 after each failed regrowth: about log2(32/3) + 2
  // failures to get there, then one per 32 + 1 steps: 500 / 33 = 15 in the
  // second half, about 35 in all. A failed attempt costs at most snes_max_it
  // (25) Newton iterations against 32 steps of typically 5-10: under 15 %.
  CHECK(o.failures <= 40);
  CHECK(o.failures_in_second_half <= 17);
  // Once the stiff phase is over the nominal step comes back within 2 x 32 steps.
  CHECK(o.steps_to_nominal_after_phase >= 0);
  CHECK(o.steps_to_nominal_after_phase <= 2 * StepController::max_patience);
}

TEST_CASE("step control: an isolated failure costs three small steps", "[solver]") {
  StepController control(0.01);
  control.failed();
  CHECK(control.step() == 0.005);
  for (int i = 0; i < 2; ++i) {
    control.succeeded();
    CHECK(control.step() == 0.005);
  }
  control.succeeded();
  CHECK(control.step() == 0.01);
  // Patience relaxes after a long calm stretch at the nominal step.
  control.failed();  // right after the regrowth: patience 3 -> 6
  CHECK(control.patience() == 6);
  for (int i = 0; i < 6; ++i) control.succeeded();
  CHECK(control.step() == 0.01);
  for (int i = 0; i < 4 * 6 + 1; ++i) control.succeeded();
  CHECK(control.patience() == 3);
}

TEST_CASE("step control: easy Newton solves bring the step back twice as fast", "[solver]") {
  // After two cut-backs (h/4), steps of at most easy_iterations Newton
  // iterations count twice: patience 3 is met after 2 steps per doubling.
  StepController easy(1.0), hard(1.0);
  for (StepController* c : {&easy, &hard}) c->failed(), c->failed();
  long easy_steps = 0, hard_steps = 0;
  while (easy.step() < 1.0) easy.succeeded(StepController::easy_iterations), ++easy_steps;
  while (hard.step() < 1.0) hard.succeeded(StepController::easy_iterations + 1), ++hard_steps;
  // The second failure came right after the first: patience 3 -> 6 -> ... ;
  // whatever it is, easy steps need half as many (rounded up).
  CHECK(easy_steps == (hard_steps + 3) / 2);
  CHECK(hard_steps == 2 * hard.patience());
}

TEST_CASE("step control: a step shortened to land on an output time leaves the step as it was", "[solver]") {
  // The run shortens a step to land on an output time (docs/output.md#output-times):
  // its success counts as any other, and the next step is the full one.
  StepController control(1.0);
  control.succeeded();  // the shortened step of 0.3, accepted
  CHECK(control.step() == 1.0);
  // A failed shortened step of 0.3 halves that, not the step of 1: half of 1
  // would be the same 0.3 again once shortened to the output time.
  CHECK(control.failed(0.3) == 0.15);
  // A failed full step halves it, whatever the attempt would have allowed.
  StepController full(1.0);
  CHECK(full.failed(1.0) == 0.5);
  CHECK(full.failed() == 0.25);
  // A checkpoint's step above the case's time.step (a restart with a smaller
  // step) is capped at it; a smaller one (after a cut-back) is kept.
  StepController restarted(0.5);
  restarted.restore({1.0, 3, 0, 10});
  CHECK(restarted.step() == 0.5);
  restarted.restore({0.125, 3, 0, 10});
  CHECK(restarted.step() == 0.125);
}
