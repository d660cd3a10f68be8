// Fully developed laminar flow in a straight duct of any cross-section: the
// inflow a port that is not round gets (its bore's own profile), on the
// inlet face's triangles of the flow mesh.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace rectify::stokes
{
  /// The axial velocity w of developed duct flow per unit mu^-1 dp/dz:
  /// -laplace(w) = 1 in the section, w = 0 on its edge, with quadratic (P2)
  /// triangles on the given triangulation. Its nodes are the triangles'
  /// vertices and edge midpoints: the trace on a face of the flow's P2
  /// velocity, so the flow mesh takes the profile without interpolation
  /// error. The edge is every triangle edge that only one triangle has.
  class DuctProfile
  {
  public:
    using Point2 = std::array<double, 2>;

    /// Throws std::invalid_argument for no triangles, an index out of range
    /// or a degenerate triangle.
    DuctProfile(std::vector<Point2> points, const std::vector<std::array<std::size_t, 3>> &triangles);

    /// w at (x, y): the P2 interpolant of the triangle holding it; zero
    /// outside every triangle (beyond a relative tolerance of 1e-9).
    double value(double x, double y) const;
    /// The integral of w over the section: the duct's R is mu length / flux.
    double flux() const { return flux_; }
    double area() const { return area_; }
    std::size_t n_nodes() const { return values_.size(); }

  private:
    struct Triangle
    {
      std::array<std::size_t, 3> vertex;
      std::array<std::size_t, 3> midpoint; ///< of the edge opposite each vertex
      double                     area;
    };
    std::vector<Point2>   points_;
    std::vector<Triangle> triangles_;
    std::vector<double>   values_; ///< at the vertices, then the midpoints
    double                flux_ = 0, area_ = 0, scale_ = 0;
  };
} // namespace rectify::stokes
