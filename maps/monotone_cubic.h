// Monotone piecewise-cubic Hermite interpolation (Fritsch-Carlson node slopes,
// as PCHIP): y(t) through the nodes (t_i, y_i), monotone wherever the data
// are, with a continuous first derivative. The kernel behind the map set's
// R(x) (log R over log x) and A_eff(x) (A over log x).
#pragma once

#include <span>
#include <vector>

namespace rectify::maps
{
  class MonotoneCubic
  {
  public:
    MonotoneCubic() = default;
    /// Preconditions (asserted): t.size() == y.size() >= 2, t strictly increasing.
    MonotoneCubic(std::span<const double> t, std::span<const double> y);

    struct Value
    {
      double value, derivative; ///< y(t), dy/dt
    };
    /// For t in [t_0, t_n]; outside, the end value with derivative 0.
    Value evaluate(double t) const;

    const std::vector<double> &nodes() const { return t_; }
    const std::vector<double> &values() const { return y_; }

  private:
    std::vector<double> t_, y_, slope_;
  };
} // namespace rectify::maps
