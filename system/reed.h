// One reed valve tip as a 1-DOF oscillator between its seat and its stop
// (thesis eqs. 3.9, 3.10, and the stop a real valve has):
//
//   m x'' + b x' + k x = F,   0 <= x <= x_stop,
//
// F the opening pressure force. Seat and stop are contact events, not
// clamps: a free reed is stopped when x falls through 0 (root of x) or rises
// through x_stop (root of x_stop - x); a seated reed lifts when F exceeds a
// tiny threshold (root of lift_force - F), a reed held at its stop leaves
// when the net force F - k x_stop turns to closing. The model and the tests
// use these same functions.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace rectify::system
{
  struct ReedConstants
  {
    double stiffness;   ///< k [N/m]
    double mass;        ///< m [kg]
    double damping;     ///< b [N s/m]
    double area;        ///< A_r [m^2]: F = dp * A_r
    double restitution; ///< rebound speed / impact speed at the seat, in [0, 1)
  };

  /// A seated reed lifts when its opening force exceeds this (1e-9 N, five
  /// orders below 1 Pa on A_r). It must not be 0: a root function that starts
  /// an integration segment at exactly 0 is masked by CVODE.
  inline constexpr double reed_lift_force = 1e-9;

  /// x'' of a free reed.
  inline double reed_acceleration(const ReedConstants &c, double x, double v, double force)
  {
    return (force - c.damping * v - c.stiffness * x) / c.mass;
  }

  /// The squeeze film's force against a reed moving at v with damping c:
  /// c v while it closes (the film's pressure rises: no limit); while it
  /// opens, the film's suction is at most `cap` (cavitation: the film cannot
  /// pull its pressure below the cavitation pressure; docs/fluid-loading.md),
  /// smoothly: cap tanh(c v / cap), which has the value, slope and curvature
  /// of c v at v = 0. cap = infinity: no limit; cap = 0: no suction.
  inline double film_force(double c, double v, double cap)
  {
    if (v <= 0.0 || !(cap < std::numeric_limits<double>::infinity()))
      return c * v;
    return cap > 0.0 ? cap * std::tanh(c * v / cap) : 0.0;
  }

  /// The film's suction limit for a pocket at absolute pressure p_pocket,
  /// cavitation at p_cav, film modal area A: (p_pocket - p_cav) A, its
  /// difference rounded off over 10 kPa near 0 (softplus) so that the force
  /// stays smooth where the pocket's pressure nears the cavitation pressure.
  inline double film_suction_cap(double p_pocket, double p_cav, double area)
  {
    constexpr double w = 1e4;
    const double     d = (p_pocket - p_cav) / w;
    return area * w * (d > 30 ? d : std::log1p(std::exp(d)));
  }

  /// A reed lifts off to x = reed_seat_tolerance (1e-13 m, far below any
  /// opening that matters), not to 0: a segment that started at x = 0 would
  /// have its impact root masked by CVODE, and a reed pushed straight back
  /// could pass its seat unseen.
  inline constexpr double reed_seat_tolerance = 1e-13;

  /// Root function: crosses zero from above at lift-off (seated) or impact (free).
  inline double reed_root(bool seated, double x, double force)
  {
    return seated ? reed_lift_force - force : x;
  }

  /// Applies a located root to (x, v) and returns whether the reed is now
  /// seated. At impact `force` is the opening force with the reed at x = 0.
  inline bool reed_on_root(const ReedConstants &c, bool seated, double force, double &x, double &v)
  {
    x = 0.0;
    if (seated)
      { // lift-off from rest, a hair above the seat (see reed_seat_tolerance)
        x = reed_seat_tolerance;
        v = 0.0;
        return false;
      }
    const double rebound = c.restitution * std::max(-v, 0.0);
    if (force <= reed_lift_force && rebound < 1e-6)
      {
        v = 0.0; // stays on the seat
        return true;
      }
    v = rebound; // bounces, or (force > 0) leaves again from rest
    return false;
  }

  /// Root function of the stop at x_stop: a free reed's impact (x_stop - x
  /// falls through 0); a held reed's release, when the net force on it at
  /// rest, F - k x_stop, falls below -reed_lift_force (the stop would have to pull).
  inline double stop_root(bool at_stop, double x, double x_stop, double net_force)
  {
    return at_stop ? net_force + reed_lift_force : x_stop - x;
  }

  /// Applies a located stop root to (x, v) and returns whether the reed is
  /// now held at its stop. A held reed leaves from rest, a hair below the
  /// stop (reed_seat_tolerance, for the same reason as at the seat). A free
  /// reed arriving at v > 0 rebounds at restitution x v, or, if that is
  /// negligible and the net force F - k x_stop at the stop holds it there,
  /// stays.
  inline bool reed_on_stop(double restitution, bool at_stop, double net_force, double x_stop, double &x, double &v)
  {
    if (at_stop)
      {
        x = x_stop - reed_seat_tolerance;
        v = 0.0;
        return false;
      }
    x                    = x_stop;
    const double rebound = restitution * std::max(v, 0.0);
    if (net_force >= -reed_lift_force && rebound < 1e-6)
      {
        v = 0.0;
        return true;
      }
    v = -rebound; // bounces, or (net force closing) leaves again from rest
    return false;
  }
} // namespace rectify::system
