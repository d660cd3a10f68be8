// Mesh files other tools read: VTU (ParaView) and Gmsh .msh 2.2 (ASCII),
// written atomically.
#pragma once

#include <filesystem>
#include <vector>

#include "mesher/tet_mesh.h"

namespace rectify::mesher
{
  /// The volume mesh with cell data "region" (0 gap, 1 slab, 2 port, 3 bulk).
  void write_vtu(const std::filesystem::path &path, const TetMesh &mesh);
  /// The boundary triangles with cell data "boundary_id".
  void write_boundary_vtu(const std::filesystem::path &path, const TetMesh &mesh);
  /// Gmsh 2.2: triangles with the boundary ids as physical tags (1 inlet,
  /// 2 outlet, 3 walls, 4 reed), tetrahedra with physical tag 10 ("fluid")
  /// and the region + 1 as elementary tag.
  void write_msh(const std::filesystem::path &path, const TetMesh &mesh);

  /// The cells' edges cut by the plane y = y0, as (x, z) segments: a
  /// section to plot.
  struct Segment2
  {
    double x0, z0, x1, z1;
  };
  std::vector<Segment2> section(const TetMesh &mesh, double y0);
} // namespace rectify::mesher
