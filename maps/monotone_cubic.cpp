#include "maps/monotone_cubic.h"

#include <algorithm>
#include <cassert>

namespace rectify::maps
{
  MonotoneCubic::MonotoneCubic(std::span<const double> t, std::span<const double> y)
    : t_(t.begin(), t.end())
    , y_(y.begin(), y.end())
  {
    assert(t_.size() == y_.size() && t_.size() >= 2);
    const std::size_t   n = t_.size();
    std::vector<double> secant(n - 1);
    for (std::size_t i = 0; i + 1 < n; ++i)
      {
        assert(t_[i + 1] > t_[i]);
        secant[i] = (y_[i + 1] - y_[i]) / (t_[i + 1] - t_[i]);
      }
    // Zero slope where the secants change sign or vanish, else the weighted
    // harmonic mean of the neighbouring secants (Fritsch & Butland 1984);
    // one-sided secants at the ends.
    slope_.assign(n, 0.0);
    slope_.front() = secant.front();
    slope_.back()  = secant.back();
    for (std::size_t i = 1; i + 1 < n; ++i)
      {
        if (secant[i - 1] * secant[i] <= 0.0)
          continue;
        const double h0 = t_[i] - t_[i - 1], h1 = t_[i + 1] - t_[i];
        const double w1 = 2 * h1 + h0, w2 = h1 + 2 * h0;
        slope_[i]       = (w1 + w2) / (w1 / secant[i - 1] + w2 / secant[i]);
      }
  }

  MonotoneCubic::Value MonotoneCubic::evaluate(double t) const
  {
    if (t <= t_.front())
      return {y_.front(), 0.0};
    if (t >= t_.back())
      return {y_.back(), 0.0};
    const auto   it = std::upper_bound(t_.begin(), t_.end(), t);
    const auto   i  = static_cast<std::size_t>(it - t_.begin()) - 1;
    const double h  = t_[i + 1] - t_[i];
    const double s = (t - t_[i]) / h, s2 = s * s, s3 = s2 * s;
    const double y0 = y_[i], y1 = y_[i + 1], m0 = slope_[i] * h, m1 = slope_[i + 1] * h;
    const double y = (2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * y1 +
                     (s3 - s2) * m1;
    const double dy =
      ((6 * s2 - 6 * s) * y0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * y1 + (3 * s2 - 2 * s) * m1) / h;
    return {y, dy};
  }
} // namespace rectify::maps
