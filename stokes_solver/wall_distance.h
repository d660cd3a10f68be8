// The distance from a point to the nearest no-slip wall (fixed walls and the
// reed) of a flow mesh: the local channel width the Schur complement's
// preconditioner weighs its Laplacian by outside the gap.
#pragma once

#include "mesher/tet_mesh.h"

#include <memory>

namespace rectify::stokes
{
  class WallDistance
  {
  public:
    /// Samples every wall and reed face at its vertices and its centroid.
    explicit WallDistance(const mesher::TetMesh &mesh);
    ~WallDistance();
    WallDistance(const WallDistance &)            = delete;
    WallDistance &operator=(const WallDistance &) = delete;

    /// Distance [m] to the nearest sample (an upper bound on the distance to
    /// the walls, within half a wall face's size of it).
    double operator()(const mesher::Point3 &p) const;

  private:
    struct Tree;
    std::unique_ptr<Tree> tree_;
  };
} // namespace rectify::stokes
