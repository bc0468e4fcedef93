// Golden-section search over one parameter: the line search of the singular families' member
// searches (nearest the seed, nearest inside the joint limits), which have no derivatives.
#pragma once

#include <cmath>

namespace dhkin {

// Narrows [low, high] by golden sections until it is at most `precision` wide and returns its
// midpoint. `evaluate(t)` scores a parameter value; `left_wins(left, right)` says whether the
// score of the left probe is at least as good as the right one's (the bracket then keeps its
// left part). Each probe is evaluated once, left probe before right at the start.
template <class Evaluate, class LeftWins>
inline double golden_section(double low, double high, double precision, Evaluate&& evaluate,
                             LeftWins&& left_wins) {
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = high - golden * (high - low), c = low + golden * (high - low);
  auto score_a = evaluate(a);
  auto score_c = evaluate(c);
  while (high - low > precision) {
    if (left_wins(score_a, score_c)) {
      high = c, c = a, score_c = score_a;
      a = high - golden * (high - low);
      score_a = evaluate(a);
    } else {
      low = a, a = c, score_a = score_c;
      c = low + golden * (high - low);
      score_c = evaluate(c);
    }
  }
  return 0.5 * (low + high);
}

}  // namespace dhkin
