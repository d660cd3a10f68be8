// Element quality and the boundary's closure checks.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "mesher/tet_mesh.h"

namespace rectify::mesher
{
  struct RegionQuality
  {
    std::size_t n_cells          = 0;
    double      volume_m3        = 0;
    double      min_dihedral_deg = 180, max_dihedral_deg = 0;
    double      max_aspect_ratio = 0; ///< longest edge / (2 sqrt(6) inradius): 1 for a regular tet
    double      min_relative_volume = 1e300; ///< volume / longest edge^3 (regular: 0.118)
    std::array<std::size_t, 7> dihedral_histogram{}; ///< min angle per cell, bins below
    std::array<std::size_t, 6> aspect_histogram{};
  };
  inline constexpr std::array<double, 6> dihedral_bin_edges_deg{1, 5, 10, 20, 30, 40};
  inline constexpr std::array<double, 5> aspect_bin_edges{2, 5, 10, 100, 1000};

  struct MeshQuality
  {
    RegionQuality                     all;
    std::array<RegionQuality, n_regions> region;
    double min_floor_angle_deg = 0; ///< smallest angle of the floor triangulation (layered cells' base)
  };

  MeshQuality measure_quality(const TetMesh &mesh);
  std::string quality_report(const MeshQuality &quality);

  /// The fluid's boundary checked as a closed surface (CGAL).
  struct SurfaceCheck
  {
    bool        closed = false, self_intersecting = true, outward = false;
    double      volume_m3 = 0; ///< enclosed volume (CGAL)
    std::size_t n_faces = 0;
  };
  /// The mesh's boundary faces (oriented as stored).
  SurfaceCheck check_surface(const TetMesh &mesh);
  /// Any triangle set; `orient`: orient it consistently first (TetGen's input
  /// has no orientation), in which case `outward` is not checked.
  SurfaceCheck check_surface(const std::vector<Point3>                        &points,
                             const std::vector<std::array<std::uint32_t, 3>> &triangles, bool orient);
} // namespace rectify::mesher
