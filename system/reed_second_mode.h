// reed_second_mode: each reed's second bending mode ([reed]
// second_mode_frequency_Hz and second_mode_root_stress_per_opening_Pa_per_m;
// the diagnosis effect `reed_second_mode`). Both modes are normalised to the
// tip with equal modal masses: the tip opening is x1 + x2, the valve's
// opening force drives both, and seat and stop hold the tip, not the reed:
// their reaction acts on both modes and keeps the tip's acceleration at
// zero while the modes' difference rings as the tip-pinned reed.
//
// Not a Component (system/component.h): it changes the reed's own
// mechanics, which Model computes for both valves (their rows, contact
// events and roots); Model asks this unit for each of its terms where the
// case has a second mode. Its states are the fixed state::outlet_reed2_x ..
// inlet_reed2_v; with it on, CVODE takes difference quotients.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "system/parameters.h"
#include "system/reed.h"
#include "system/states.h"

namespace rectify::system
{
  class ReedSecondMode
  {
  public:
    /// None where the case has no second mode (its frequency 0). `reed`:
    /// the first mode's constants (its modal mass and damping ratio are the
    /// second's).
    static std::optional<ReedSecondMode> make(const SystemParameters &p, const ReedConstants &reed)
    {
      if (!(p.reed.second_mode_frequency_Hz > 0.0))
        return std::nullopt;
      const double w2 = 2.0 * M_PI * p.reed.second_mode_frequency_Hz;
      const double k  = reed.mass * w2 * w2;
      return ReedSecondMode(k, 2.0 * p.reed.damping_ratio * std::sqrt(k * reed.mass),
                            p.reed.second_mode_root_stress_per_opening_Pa_per_m);
    }

    double stiffness() const { return k_; } ///< k_r2 [N/m]
    double damping() const { return b_; }   ///< b_r2 [N s/m]

    /// Valve v's (0 outlet, 1 inlet) mode displacement state; its velocity follows.
    static std::size_t x_state(std::size_t v) { return v == 0 ? state::outlet_reed2_x : state::inlet_reed2_x; }
    /// The first mode's displacement state.
    static std::size_t first(std::size_t v) { return v == 0 ? state::outlet_reed_x : state::inlet_reed_x; }

    /// Valve v's tip opening: both modes.
    static double tip(std::size_t v, std::span<const double> y) { return y[first(v)] + y[x_state(v)]; }
    /// Valve v's root stress (and its rate) with the first mode's per unit opening.
    double stress(std::size_t v, std::span<const double> y, double first_per_opening) const
    {
      return first_per_opening * y[first(v)] + stress_ * y[x_state(v)];
    }
    double stress_rate(std::size_t v, std::span<const double> y, double first_per_opening) const
    {
      return first_per_opening * y[first(v) + 1] + stress_ * y[x_state(v) + 1];
    }

    /// The reaction of a seat (or stop) holding the tip of valve v under the
    /// opening force `force`: m (a1 + a2) = 2 (F + reaction) - b1 v1 - k1 x1
    /// - b2 v2 - k2 x2 = 0.
    double seat_reaction(const ReedConstants &reed, double force, double x1, double v1, double x2, double v2) const
    {
      return -force + 0.5 * (reed.damping * v1 + reed.stiffness * x1 + b_ * v2 + k_ * x2);
    }
    double seat_reaction(const ReedConstants &reed, double force, std::size_t v, std::span<const double> y) const
    {
      const std::size_t i = first(v), j = x_state(v);
      return seat_reaction(reed, force, y[i], y[i + 1], y[j], y[j + 1]);
    }

    /// Valve v's mode rows under the net force on the tip (the opening force
    /// and a holding contact's reaction).
    void rhs(std::size_t v, std::span<const double> y, double net_force, double mass, std::span<double> ydot) const
    {
      const std::size_t j = x_state(v);
      ydot[j]             = y[j + 1];
      ydot[j + 1]         = (net_force - b_ * y[j + 1] - k_ * y[j]) / mass;
    }

    /// The states its rows read: its own beside the first mode's and the
    /// flows' (`flow`), the first mode's row its own too.
    static void reads(std::vector<std::vector<std::size_t>> &r, const std::vector<std::size_t> &flow)
    {
      for (std::size_t v = 0; v < 2; ++v)
        {
          const std::size_t i = first(v), j = x_state(v);
          r[i + 1].insert(r[i + 1].end(), {j, j + 1});
          r[j]     = {j + 1};
          r[j + 1] = flow;
          r[j + 1].insert(r[j + 1].end(), {i, i + 1, j, j + 1});
        }
    }

    /// An impact of valve v's tip on the seat or stop at `level`: both modes
    /// moved by half the tip's overshoot; an impulse on the tip (equal on
    /// both modes) sets its velocity to `rebound`. Returns the tip's
    /// velocity before.
    static double impact(std::size_t v, std::span<double> y, double level, const auto &rebound_of)
    {
      double &x1 = y[first(v)], &v1 = y[first(v) + 1], &x2 = y[x_state(v)], &v2 = y[x_state(v) + 1];
      const double s = x1 + x2 - level;
      x1 -= 0.5 * s;
      x2 -= 0.5 * s;
      const double tip_v   = v1 + v2;
      const double rebound = rebound_of(tip_v);
      v1 += 0.5 * (rebound - tip_v);
      v2 += 0.5 * (rebound - tip_v);
      return tip_v;
    }

  private:
    ReedSecondMode(double k, double b, double stress)
      : k_(k)
      , b_(b)
      , stress_(stress)
    {}
    double k_, b_;
    double stress_; ///< root stress per unit opening of this mode [Pa/m]
  };
} // namespace rectify::system
