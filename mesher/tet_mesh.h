// A tetrahedral mesh of the fluid domain with boundary ids: what the mesher
// produces and the solvers read (directly, or through to_dealii.h).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace rectify::mesher
{
  using Point3 = std::array<double, 3>;

  /// Boundary ids on every boundary face (docs/mesher.md).
  enum BoundaryId : std::uint8_t
  {
    inlet  = 1, ///< the port's face z = -port_length
    outlet = 2, ///< the pocket face named by [geometry] outlet_face
    walls  = 3, ///< every fixed wall, the seat and the closed part of the gap included
    reed   = 4  ///< the reed's surface: underside, top, sides and tip
  };
  std::string boundary_name(std::uint8_t id);

  /// Where a cell came from (stored as deal.II material id).
  enum Region : std::uint8_t
  {
    gap  = 0, ///< the layered gap under the reed
    slab = 1, ///< the rest of the layered slab near the seat (beside and above the reed)
    port = 2, ///< the extruded port
    bulk = 3  ///< TetGen's tetrahedra in the pocket above the slab
  };
  inline constexpr int n_regions = 4;
  std::string region_name(std::uint8_t region);

  struct BoundaryFace
  {
    std::array<std::uint32_t, 3> vertices; ///< ordered so that the normal points out of the fluid
    std::uint8_t                  id;
  };

  struct TetMesh
  {
    std::vector<Point3>                        vertices;
    std::vector<std::array<std::uint32_t, 4>> cells;  ///< positively oriented (det > 0)
    std::vector<std::uint8_t>                  region; ///< per cell
    std::vector<BoundaryFace>                  boundary;
  };

  double signed_volume(const Point3 &a, const Point3 &b, const Point3 &c, const Point3 &d);
  double triangle_area(const Point3 &a, const Point3 &b, const Point3 &c);
  double cell_volume(const TetMesh &mesh, std::size_t cell);
} // namespace rectify::mesher
