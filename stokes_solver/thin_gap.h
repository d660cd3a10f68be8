// Thin-gap (lubrication, Reynolds equation) theory for a gap of height
// h(x, y) between two nearly parallel walls: the flow per unit width is
// -h^3 / (12 mu) grad p, so div(h^3 grad p) = 0. Solved by finite volumes on
// a uniform square grid: the independent estimate R(x) is compared with
// (docs/stokes.md), exact for thin gaps apart from the port's entrance and
// the gap's exit.
#pragma once

#include <functional>

#include "common/valve_geometry.h"

namespace rectify::stokes
{
  /// What a point of the thin-gap domain is.
  enum class GapCell
  {
    open,   ///< flow, pressure unknown
    source, ///< the port's mouth: pressure 1
    sink,   ///< the gap's exit: pressure 0
    closed  ///< no flow
  };

  struct ThinGapProblem
  {
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0; ///< the rectangle holding the domain
    double spacing = 0;                    ///< grid spacing (cells are squares; the rectangle is rounded up)
    double viscosity_Pa_s = 0;
    std::function<double(double, double)>  height;   ///< h(x, y) > 0 where open
    std::function<GapCell(double, double)> kind;     ///< of each cell's centre
    bool   x0_is_sink = false, x1_is_sink = true, y0_is_sink = true, y1_is_sink = true; ///< else a wall
  };

  struct ThinGapResult
  {
    double      R_Pa_s_per_m3 = 0; ///< (p_source - p_sink) / Q
    std::size_t n_unknowns    = 0;
  };

  /// Solves the Reynolds equation; throws std::runtime_error if the solver
  /// fails or no flow leaves the source.
  ThinGapResult solve_thin_gap(const ThinGapProblem &problem);

  /// The valve's gap under the reed at a tip opening: h = opening * phi(x)
  /// over the reed's outline (any outline, fillets included), every port's
  /// mouth a source at one pressure, the seat beyond the reed's edge the
  /// sink, the clamp a wall, closed where x < closed_to_m (the mesher's
  /// cut-off). Returns the gap's R (Richardson-extrapolated from
  /// `spacing_m` and twice it: the staircase edges make the error first
  /// order) plus the ports' bores in parallel (ports_bore_R).
  double thin_gap_valve_R(const ValveGeometry &geometry, const std::function<double(double)> &phi,
                          double opening_m, double closed_to_m, double viscosity_Pa_s, double spacing_m);

  /// One port's bore as a straight duct of its cross-section, fully developed
  /// flow: a circle's Hagen-Poiseuille 128 mu l / (pi D^4); a polygon's
  /// mu l / integral(w), -laplace(w) = 1 in the section, w = 0 on its edge,
  /// solved by finite volumes on squares of `spacing_m` and twice it
  /// (Richardson).
  double port_bore_R(const Port &port, double viscosity_Pa_s, double spacing_m);

  /// The ports' bores in parallel, 1 / sum(1 / R_i), each at a spacing of
  /// 1/40 of its narrowest width.
  double ports_bore_R(const ValveGeometry &geometry, double viscosity_Pa_s);
} // namespace rectify::stokes
