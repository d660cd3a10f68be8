#include "mesher/tet_mesh.h"

#include <cmath>

namespace rectify::mesher
{
  std::string boundary_name(std::uint8_t id)
  {
    switch (id)
      {
        case inlet:
          return "inlet";
        case outlet:
          return "outlet";
        case walls:
          return "walls";
        case reed:
          return "reed";
        default:
          return "unknown";
      }
  }

  std::string region_name(std::uint8_t region)
  {
    switch (region)
      {
        case gap:
          return "gap";
        case slab:
          return "slab";
        case port:
          return "port";
        case bulk:
          return "bulk";
        default:
          return "unknown";
      }
  }

  double signed_volume(const Point3 &a, const Point3 &b, const Point3 &c, const Point3 &d)
  {
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
            u[2] * (v[0] * w[1] - v[1] * w[0])) /
           6.0;
  }

  double triangle_area(const Point3 &a, const Point3 &b, const Point3 &c)
  {
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    return 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  }

  double cell_volume(const TetMesh &m, std::size_t c)
  {
    const auto &v = m.cells[c];
    return signed_volume(m.vertices[v[0]], m.vertices[v[1]], m.vertices[v[2]], m.vertices[v[3]]);
  }
} // namespace rectify::mesher
