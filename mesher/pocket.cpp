#include <algorithm>
#include <cmath>

#include "mesher/bulk_tetgen.h"
#include "mesher/layout.h"
#include "mesher/mesher.h"

namespace rectify::mesher::detail
{
  std::string build_pocket(const Layout &lay, const PlanarMesh &floor, TetMesh &all)
  {
    const auto &s  = lay.s;
    const auto  nf = static_cast<std::uint32_t>(floor.points.size());
    const auto  N1 = static_cast<std::uint32_t>(lay.N + 1);
    // Its closed surface: the slab's top (the floor triangulation lifted),
    // four walls and the ceiling.
    std::vector<Point3>                        surface_points;
    std::vector<std::uint32_t>                 surface_to_global;
    std::vector<std::array<std::uint32_t, 3>> surface_triangles;
    for (std::uint32_t i = 0; i < nf; ++i)
      {
        surface_points.push_back(all.vertices[i * N1 + lay.N]);
        surface_to_global.push_back(i * N1 + lay.N);
      }
    for (const auto &t : floor.triangles)
      surface_triangles.push_back(t);
    const double wall_size = s.size_far_m;
    auto new_point = [&](const Point3 &p) {
      surface_points.push_back(p);
      surface_to_global.push_back(static_cast<std::uint32_t>(all.vertices.size()));
      all.vertices.push_back(p);
      return static_cast<std::uint32_t>(surface_points.size() - 1);
    };
    auto subdivisions = [&](double length) {
      return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(length / wall_size - 1e-9)));
    };
    // Vertical corner edges (bottom: the slab top's corner; top: the ceiling's).
    const double hp = 0.5 * lay.Wp;
    const std::array<Point2, 4> corners{{{0, -hp}, {lay.Lp, -hp}, {lay.Lp, hp}, {0, hp}}};
    auto floor_index = [&](const Point2 &p) {
      for (std::uint32_t i = 0; i < nf; ++i)
        if (floor.points[i] == p)
          return i;
      throw MeshError("internal: a pocket corner is missing from the floor triangulation");
    };
    std::array<std::vector<std::uint32_t>, 4> corner_edge; // bottom to top, surface indices
    for (int c = 0; c < 4; ++c)
      {
        const std::uint32_t bottom = floor_index(corners[c]);
        const double        z0     = surface_points[bottom][2];
        const std::size_t   n      = subdivisions(lay.Hp - z0);
        corner_edge[c].push_back(bottom);
        for (std::size_t k = 1; k <= n; ++k)
          corner_edge[c].push_back(new_point(
            {corners[c][0], corners[c][1], k == n ? lay.Hp : z0 + (lay.Hp - z0) * k / n}));
      }
    // Top edges: from corner c to corner c + 1, interior points only.
    std::array<std::vector<std::uint32_t>, 4> top_edge;
    for (int c = 0; c < 4; ++c)
      {
        const auto &a = corners[c], &b = corners[(c + 1) % 4];
        const std::size_t n = subdivisions(std::hypot(b[0] - a[0], b[1] - a[1]));
        for (std::size_t k = 1; k < n; ++k)
          {
            const double w = static_cast<double>(k) / static_cast<double>(n);
            top_edge[c].push_back(new_point({a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), lay.Hp}));
          }
      }
    // A planar facet: a loop of surface points, meshed in 2D (u, v) coordinates
    // without splitting its edges (they are shared).
    auto add_facet = [&](const std::vector<std::uint32_t> &loop, auto to_uv, auto from_uv) {
      PlanarInput in;
      for (auto id : loop)
        in.points.push_back(to_uv(surface_points[id]));
      for (std::uint32_t k = 0; k < loop.size(); ++k)
        in.segments.push_back({k, (k + 1) % static_cast<std::uint32_t>(loop.size())});
      in.size            = [wall_size](const Point2 &) { return wall_size; };
      in.min_angle_deg   = s.min_angle_deg;
      in.refine_segments = false;
      const PlanarMesh facet = mesh_planar(in);
      std::vector<std::uint32_t> ids(loop);
      for (std::size_t k = loop.size(); k < facet.points.size(); ++k)
        ids.push_back(new_point(from_uv(facet.points[k])));
      for (const auto &t : facet.triangles)
        surface_triangles.push_back({ids[t[0]], ids[t[1]], ids[t[2]]});
    };
    // Walls: side c runs from corner c to corner c + 1 along the floor's edge.
    for (int c = 0; c < 4; ++c)
      {
        const auto  &a = corners[c], &b = corners[(c + 1) % 4];
        const double dx = b[0] - a[0], dy = b[1] - a[1], len = std::hypot(dx, dy);
        // Floor boundary points on this side, ordered from a to b.
        std::vector<std::pair<double, std::uint32_t>> side;
        for (std::uint32_t i = 0; i < nf; ++i)
          {
            const auto &p = floor.points[i];
            const bool on = (dx == 0) ? p[0] == a[0] : p[1] == a[1];
            if (on)
              side.emplace_back(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len, i);
          }
        std::sort(side.begin(), side.end());
        std::vector<std::uint32_t> loop;
        for (const auto &[u, i] : side)
          loop.push_back(i);
        const auto &up = corner_edge[(c + 1) % 4];
        loop.insert(loop.end(), up.begin() + 1, up.end());
        loop.insert(loop.end(), top_edge[c].rbegin(), top_edge[c].rend());
        const auto &down = corner_edge[c];
        loop.insert(loop.end(), down.rbegin(), down.rend() - 1);
        const double ux = dx / len, uy = dy / len;
        add_facet(
          loop,
          [&](const Point3 &p) { return Point2{(p[0] - a[0]) * ux + (p[1] - a[1]) * uy, p[2]}; },
          [&](const Point2 &q) { return Point3{a[0] + q[0] * ux, a[1] + q[0] * uy, q[1]}; });
      }
    {
      std::vector<std::uint32_t> loop;
      for (int c = 0; c < 4; ++c)
        {
          loop.push_back(corner_edge[c].back());
          loop.insert(loop.end(), top_edge[c].begin(), top_edge[c].end());
        }
      add_facet(
        loop, [](const Point3 &p) { return Point2{p[0], p[1]}; },
        [&](const Point2 &q) { return Point3{q[0], q[1], lay.Hp}; });
    }
    const TetgenResult tg = tetrahedralize_closed_surface(
      surface_points, surface_triangles,
      {s.tetgen_radius_edge_ratio, s.tetgen_min_dihedral_deg, s.tetgen_max_volume_m3});
    const auto n_surface = static_cast<std::uint32_t>(surface_points.size());
    const auto first_new = static_cast<std::uint32_t>(all.vertices.size());
    all.vertices.insert(all.vertices.end(), tg.new_points.begin(), tg.new_points.end());
    for (const auto &c : tg.cells)
      {
        std::array<std::uint32_t, 4> cell;
        for (int k = 0; k < 4; ++k)
          cell[k] = c[k] < n_surface ? surface_to_global[c[k]] : first_new + (c[k] - n_surface);
        all.cells.push_back(cell);
        all.region.push_back(tag_bulk);
      }
    return tg.switches;
  }
} // namespace rectify::mesher::detail
