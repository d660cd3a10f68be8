// The mesh straight into a deal.II Triangulation<3> (no file round trip).
#pragma once

#include "mesher/tet_mesh.h"

namespace dealii
{
  template <int dim, int spacedim>
  class Triangulation;
}

namespace rectify::mesher
{
  /// Fills `triangulation` (which must be empty) with the mesh's tetrahedra:
  /// material id = region, boundary ids 1 inlet, 2 outlet, 3 walls, 4 reed.
  /// Checks every cell's orientation as deal.II sees it (its release build
  /// accepts inverted cells silently) and throws MeshError if one is not
  /// positive.
  void fill_triangulation(const TetMesh &mesh, dealii::Triangulation<3, 3> &triangulation);
} // namespace rectify::mesher
