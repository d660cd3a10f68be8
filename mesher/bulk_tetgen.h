// TetGen (libtet) on a closed, triangulated surface: the pocket above the slab.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mesher/tet_mesh.h"

namespace rectify::mesher
{
  struct TetgenOptions
  {
    double radius_edge_ratio = 1.5;
    double min_dihedral_deg  = 12.0;
    double max_volume_m3     = 0.0; ///< 0: none
  };

  struct TetgenResult
  {
    /// Points TetGen added (Steiner points), after the input points.
    std::vector<Point3>                        new_points;
    /// Tetrahedra; indices below the number of input points are input points,
    /// the rest index new_points (minus that number).
    std::vector<std::array<std::uint32_t, 4>> cells;
    std::string                                switches;
  };

  /// Tetrahedralises the volume enclosed by `triangles` (a closed surface over
  /// `points`), keeping every input triangle (-Y: no Steiner points on the
  /// boundary). Throws MeshError with TetGen's cause on failure.
  TetgenResult tetrahedralize_closed_surface(const std::vector<Point3>                        &points,
                                             const std::vector<std::array<std::uint32_t, 3>> &triangles,
                                             const TetgenOptions                              &options);
} // namespace rectify::mesher
