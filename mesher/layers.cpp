#include <algorithm>
#include <cmath>
#include <cstdio>

#include "mesher/layout.h"

namespace rectify::mesher::detail
{
  /// Splits the prism between two levels of a triangle into three
  /// tetrahedra. The diagonal of each side face runs from the lower-numbered
  /// floor vertex's `lo` point to the higher-numbered one's `hi` point, so
  /// neighbouring prisms share their side faces' diagonals.
  void split_prism(std::array<std::uint32_t, 3> tri, const std::array<std::uint32_t, 3> &lo,
                   const std::array<std::uint32_t, 3> &hi, std::uint8_t tag, TetMesh &mesh)
  {
    std::array<int, 3> order{0, 1, 2};
    std::sort(order.begin(), order.end(), [&](int i, int j) { return tri[i] < tri[j]; });
    const auto a = order[0], b = order[1], c = order[2];
    mesh.cells.push_back({lo[a], lo[b], lo[c], hi[c]});
    mesh.cells.push_back({lo[a], lo[b], hi[b], hi[c]});
    mesh.cells.push_back({lo[a], hi[a], hi[b], hi[c]});
    for (int k = 0; k < 3; ++k)
      mesh.region.push_back(tag);
  }

  void build_slab(const Layout &lay, const PlanarMesh &floor, const std::vector<FloorPart> &where_tri,
                  TetMesh &all)
  {
    const auto nf = static_cast<std::uint32_t>(floor.points.size());
    const auto  N1 = static_cast<std::uint32_t>(lay.N + 1);
    all.vertices.resize(static_cast<std::size_t>(nf) * N1);
    for (std::uint32_t i = 0; i < nf; ++i)
      for (long m = 0; m <= lay.N; ++m)
        all.vertices[i * N1 + m] = {floor.points[i][0], floor.points[i][1],
                                    lay.level(floor.points[i][0], floor.points[i][1], m)};
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      {
        const auto &t = floor.triangles[f];
        for (long m = 0; m < lay.N; ++m)
          {
            std::uint8_t tag = tag_slab;
            if (where_tri[f] != FloorPart::outside)
              {
                if (m < lay.Ng)
                  tag = where_tri[f] == FloorPart::closed ? tag_closed_solid : tag_gap;
                else if (m < lay.Ng + lay.Nr)
                  tag = tag_reed_solid;
              }
            const auto mm = static_cast<std::uint32_t>(m);
            split_prism(t, {t[0] * N1 + mm, t[1] * N1 + mm, t[2] * N1 + mm},
                        {t[0] * N1 + mm + 1, t[1] * N1 + mm + 1, t[2] * N1 + mm + 1}, tag, all);
          }
      }
  }

  void build_port(const Layout &lay, const PlanarMesh &floor, const std::vector<FloorPart> &where_tri,
                  const std::vector<int> &port_of, const std::vector<PortPolygon> &ports, TetMesh &all)
  {
    const auto nf = static_cast<std::uint32_t>(floor.points.size());
    const auto N1 = static_cast<std::uint32_t>(lay.N + 1);
    // Each port's bore in layers of about port_layer_m, down to its inlet face z = -length.
    std::vector<std::uint32_t> n_layers;
    for (const auto &p : ports)
      n_layers.push_back(static_cast<std::uint32_t>(std::max(1.0, std::ceil(p.length / lay.s.port_layer_m - 1e-9))));
    std::vector<std::int64_t> port_column(nf, -1); // first vertex of the column below the floor
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      if (where_tri[f] == FloorPart::port)
        {
          const auto   k   = static_cast<std::size_t>(port_of[f]);
          const double ell = ports[k].length;
          const auto   n   = n_layers[k];
          for (auto v : floor.triangles[f])
            if (port_column[v] < 0)
              {
                port_column[v] = static_cast<std::int64_t>(all.vertices.size());
                for (std::uint32_t i = 1; i <= n; ++i)
                  all.vertices.push_back({floor.points[v][0], floor.points[v][1], i == n ? -ell : -ell * i / n});
              }
        }
    auto port_vertex = [&](std::uint32_t v, std::uint32_t k) {
      return k == 0 ? v * N1 : static_cast<std::uint32_t>(port_column[v] + k - 1);
    };
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      if (where_tri[f] == FloorPart::port)
        {
          const auto &t = floor.triangles[f];
          for (std::uint32_t k = 0; k < n_layers[static_cast<std::size_t>(port_of[f])]; ++k)
            split_prism(t, {port_vertex(t[0], k), port_vertex(t[1], k), port_vertex(t[2], k)},
                        {port_vertex(t[0], k + 1), port_vertex(t[1], k + 1), port_vertex(t[2], k + 1)},
                        tag_port, all);
        }
  }

  std::string where(const Point3 &p)
  {
    char buf[128];
    std::snprintf(buf, sizeof(buf), "(%.6g, %.6g, %.6g) mm", p[0] * 1e3, p[1] * 1e3, p[2] * 1e3);
    return buf;
  }
} // namespace rectify::mesher::detail
