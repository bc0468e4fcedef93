// Brent's minimisation over one parameter, without derivatives (R. P. Brent, "Algorithms for
// Minimization without Derivatives", 1973, chapter 5): the line search of the offset wrist's
// nearest member (q6 free at q5 = 0; offset.hpp). Where the scores near the best point lie on a
// parabola it steps to the parabola's vertex (superlinear convergence on a smooth minimum: ~10
// scores to 1e-9 where golden sections take ~38); elsewhere (kinks, infinite scores of points
// without a member) it takes a golden-section step, so it never does much worse than golden
// sections.
#pragma once

#include <cmath>

namespace dhkin {

// The minimum of `evaluate` over [low, high] to `precision`: returns the best point scored,
// which lies within precision / 2 of the minimum of a function unimodal on [low, high] (the
// bracket that holds the minimum ends with the point within precision / 2 of both its ends).
// `start` (inside the bracket) and its score `start_score` are where the search begins: the
// best point of a grid, already scored. No two scored points lie closer than precision / 4.
// Scores may be infinite (no parabola is fitted through them).
template <class Evaluate>
inline double brent_minimum(double low, double high, double precision, double start,
                            double start_score, Evaluate&& evaluate) {
  const double golden = 0.5 * (3.0 - std::sqrt(5.0));  // the smaller golden-section ratio
  const double least_step = 0.25 * precision;           // no two scores closer than this
  const double close_enough = 2.0 * least_step;         // the stop: best within this of both ends
  double a = low, b = high;
  // best: the best point so far; second: the second best; third: the previous second
  double best = start, second = start, third = start;
  double best_score = start_score, second_score = start_score, third_score = start_score;
  double step = 0.0, step_before = 0.0;  // the last two steps taken
  for (;;) {
    const double middle = 0.5 * (a + b);
    if (best - a <= close_enough && b - best <= close_enough) return best;
    bool parabolic = false;
    if (std::abs(step_before) > least_step && std::isfinite(best_score) &&
        std::isfinite(second_score) && std::isfinite(third_score)) {
      // the vertex of the parabola through the three points: best + p / q
      const double r = (best - second) * (best_score - third_score);
      double q = (best - third) * (best_score - second_score);
      double p = (best - third) * q - (best - second) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) p = -p;
      q = std::abs(q);
      const double older_step = step_before;
      step_before = step;
      // accepted inside the bracket, and shorter than half the step before the last (else the
      // parabolas are not converging: a golden section instead)
      if (std::abs(p) < std::abs(0.5 * q * older_step) && p > q * (a - best) &&
          p < q * (b - best)) {
        step = p / q;
        const double next = best + step;
        if (next - a < close_enough || b - next < close_enough) {
          step = std::copysign(least_step, middle - best);
        }
        parabolic = true;
      }
    }
    if (!parabolic) {  // golden section of the larger part of the bracket
      step_before = best >= middle ? a - best : b - best;
      step = golden * step_before;
    }
    const double next =
        std::abs(step) >= least_step ? best + step : best + std::copysign(least_step, step);
    const double score = evaluate(next);
    if (score <= best_score) {
      (next >= best ? a : b) = best;
      third = second, third_score = second_score;
      second = best, second_score = best_score;
      best = next, best_score = score;
    } else {
      (next < best ? a : b) = next;
      if (score <= second_score || second == best) {
        third = second, third_score = second_score;
        second = next, second_score = score;
      } else if (score <= third_score || third == best || third == second) {
        third = next, third_score = score;
      }
    }
  }
}

}  // namespace dhkin
