// The minimum of a function of one variable that has one minimum in a
// bracket, by golden section (the drive's frequency in measured_run.cpp, a
// sensor's delay in sensors.cpp).
#pragma once

#include <cmath>

namespace rectify::diagnosis
{
  /// The bracket [a, b] a golden-section search ends with, and its two
  /// interior points c < d with their values.
  struct GoldenBracket
  {
    double a = 0, b = 0, c = 0, fc = 0, d = 0, fd = 0;
  };

  /// Shrinks [a, b] by the golden ratio per step, keeping the side of the
  /// lower interior point (one new evaluation of f a step), for at most
  /// `max_steps` steps and while the bracket is wider than `width`.
  template <class F>
  GoldenBracket golden_section(F &&f, double a, double b, int max_steps, double width = 0)
  {
    const double  g = 0.5 * (std::sqrt(5.0) - 1.0);
    GoldenBracket s{a, b, b - g * (b - a), 0, a + g * (b - a), 0};
    s.fc = f(s.c);
    s.fd = f(s.d);
    for (int i = 0; i < max_steps && s.b - s.a > width; ++i)
      if (s.fc < s.fd)
        {
          s.b  = s.d;
          s.d  = s.c;
          s.fd = s.fc;
          s.c  = s.b - g * (s.b - s.a);
          s.fc = f(s.c);
        }
      else
        {
          s.a  = s.c;
          s.c  = s.d;
          s.fc = s.fd;
          s.d  = s.a + g * (s.b - s.a);
          s.fd = f(s.d);
        }
    return s;
  }
} // namespace rectify::diagnosis
