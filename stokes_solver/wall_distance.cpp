#include "stokes_solver/wall_distance.h"

#include <boost/geometry.hpp>
#include <boost/geometry/index/rtree.hpp>

#include <cmath>
#include <iterator>
#include <stdexcept>
#include <vector>

namespace rectify::stokes
{
  namespace bg = boost::geometry;
  using BoostPoint = bg::model::point<double, 3, bg::cs::cartesian>;

  struct WallDistance::Tree
  {
    bg::index::rtree<BoostPoint, bg::index::quadratic<16>> points;
  };

  WallDistance::WallDistance(const mesher::TetMesh &mesh) : tree_(std::make_unique<Tree>())
  {
    std::vector<BoostPoint> samples;
    for (const auto &face : mesh.boundary)
      if (face.id == mesher::walls || face.id == mesher::reed)
        {
          double c[3] = {0, 0, 0};
          for (const auto v : face.vertices)
            {
              const auto &p = mesh.vertices[v];
              samples.emplace_back(p[0], p[1], p[2]);
              for (int d = 0; d < 3; ++d)
                c[d] += p[d] / 3;
            }
          samples.emplace_back(c[0], c[1], c[2]);
        }
    if (samples.empty())
      throw std::invalid_argument("the flow mesh has no wall or reed faces: no channel width for the Schur preconditioner");
    tree_->points = decltype(tree_->points)(samples.begin(), samples.end()); // packed: duplicates are harmless
  }

  WallDistance::~WallDistance() = default;

  double WallDistance::operator()(const mesher::Point3 &p) const
  {
    const BoostPoint         q(p[0], p[1], p[2]);
    std::vector<BoostPoint> nearest;
    tree_->points.query(bg::index::nearest(q, 1), std::back_inserter(nearest));
    return bg::distance(q, nearest.front());
  }
} // namespace rectify::stokes
