// Plane geometry for the valve's outlines (the reed, the ports): simple
// polygons in the seat plane, metres. The predicates (simplicity, which side
// a point lies on) are CGAL's exact ones; distances and areas are plain
// floating point.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <vector>

namespace rectify::geometry
{
  using XY      = std::array<double, 2>;
  using Polygon = std::vector<XY>; ///< closed implicitly (last point joins the first)

  /// Signed area: positive if counter-clockwise.
  double signed_area(const Polygon &polygon);
  double perimeter(const Polygon &polygon);
  /// The polygon's area centroid.
  XY centroid(const Polygon &polygon);

  /// If the polygon is not simple: the first pair of edges (i, j), edge i
  /// from point i to point i+1, that cross or touch other than at a shared
  /// corner; also a repeated point or fewer than 3 points (then j = i).
  std::optional<std::array<std::size_t, 2>> first_self_intersection(const Polygon &polygon);

  enum class Side
  {
    inside,
    on_boundary,
    outside
  };
  /// Where `p` lies; the polygon must be simple.
  Side side_of(const Polygon &polygon, const XY &p);

  /// Distance from `p` to the segment [a, b].
  double distance_to_segment(const XY &p, const XY &a, const XY &b);
  /// Distance from `p` to the polygon's boundary.
  double distance_to_boundary(const Polygon &polygon, const XY &p);
  /// Smallest distance between the two boundaries (0 if they cross or touch).
  double boundary_distance(const Polygon &a, const Polygon &b);

  /// The polygon with its corners rounded: corner i by an arc of radius
  /// radii[i] (0: sharp) tangent to both edges, in steps of at most
  /// `max_step_rad`. The polygon must be counter-clockwise. Throws
  /// std::invalid_argument naming the corner if a radius does not fit
  /// (its tangent points would pass the middle of an edge).
  Polygon rounded(const Polygon &polygon, const std::vector<double> &radii, double max_step_rad);

  /// A circle as a regular polygon of n sides whose area is the circle's.
  Polygon circle_polygon(const XY &center, double radius, std::size_t n);

  /// The polygon's narrowest width: the smallest distance from a corner to
  /// an edge that lies further than 1.5 times that distance from it along
  /// the boundary (across a neck or a slot, not to the neighbouring edges of
  /// a finely drawn curve).
  double narrowest_width(const Polygon &polygon);

  /// The intervals [y0, y1] where the line x = const lies inside the
  /// polygon, in increasing y (empty if it misses it).
  std::vector<std::array<double, 2>> chord_intervals(const Polygon &polygon, double x);

  /// The polygon's width along the line x = const: the chords' summed length.
  double chord_width(const Polygon &polygon, double x);

  /// How far along both its edges each corner's fillet reaches:
  /// radii[i] / |tan(interior angle / 2)| (a reflex corner's too).
  std::vector<double> fillet_tangent_lengths(const Polygon &polygon, const std::vector<double> &radii);

  /// Interior angle at each corner [rad] (of a counter-clockwise polygon).
  std::vector<double> interior_angles(const Polygon &polygon);
} // namespace rectify::geometry
