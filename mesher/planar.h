// Planar constrained Delaunay meshing (CGAL Mesh_2): the seat's floor and the
// flat walls of the pocket.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace rectify::mesher
{
  using Point2 = std::array<double, 2>;

  struct PlanarInput
  {
    std::vector<Point2>                        points;   ///< input vertices
    std::vector<std::array<std::uint32_t, 2>> segments; ///< constrained edges between them
    /// Target edge length at a point (in the plane's coordinates).
    std::function<double(const Point2 &)> size;
    double min_angle_deg = 25.0;
    /// false: the constrained edges are never split (their points are shared
    /// with neighbouring faces); true: split as needed.
    bool refine_segments = true;
  };

  struct PlanarMesh
  {
    std::vector<Point2> points; ///< the input points first, in input order
    std::vector<std::array<std::uint32_t, 3>> triangles; ///< counter-clockwise
    /// Per point: true if it lies on a constrained edge (input points included).
    std::vector<bool> on_segment;
  };

  /// Triangulates the bounded region enclosed by the segments and refines it
  /// to the size and angle bounds. Constraint crossings become vertices.
  PlanarMesh mesh_planar(const PlanarInput &input);
} // namespace rectify::mesher
