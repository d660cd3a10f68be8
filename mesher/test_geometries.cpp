#include "mesher/test_geometries.h"

#include <cmath>
#include <functional>

#include "mesher/layout.h"
#include "mesher/planar.h"

namespace rectify::mesher
{
  namespace
  {
    /// Regular polygon with the circle's area, counter-clockwise.
    std::vector<Point2> polygon(double radius, long sides)
    {
      const double n = static_cast<double>(sides);
      const double R = radius * std::sqrt(2 * M_PI / (n * std::sin(2 * M_PI / n)));
      std::vector<Point2> p;
      for (long k = 0; k < sides; ++k)
        p.push_back({R * std::cos(2 * M_PI * k / n), R * std::sin(2 * M_PI * k / n)});
      return p;
    }

    void add_loop(PlanarInput &in, const std::vector<Point2> &loop)
    {
      const auto first = static_cast<std::uint32_t>(in.points.size());
      for (const auto &p : loop)
        in.points.push_back(p);
      const auto n = static_cast<std::uint32_t>(loop.size());
      for (std::uint32_t k = 0; k < n; ++k)
        in.segments.push_back({first + k, first + (k + 1) % n});
    }

    /// Extrudes the triangles `use` of `floor` between the levels z[0] < ... (or >)
    /// z[n]; vertex ids of column i are `column[i] + k`.
    void extrude(const PlanarMesh &floor, const std::vector<bool> &use, const std::vector<double> &z,
                 std::vector<std::int64_t> &column, std::uint8_t region, TetMesh &m)
    {
      for (std::size_t f = 0; f < floor.triangles.size(); ++f)
        if (use[f])
          for (auto v : floor.triangles[f])
            if (column[v] < 0)
              {
                column[v] = static_cast<std::int64_t>(m.vertices.size());
                for (double zk : z)
                  m.vertices.push_back({floor.points[v][0], floor.points[v][1], zk});
              }
      for (std::size_t f = 0; f < floor.triangles.size(); ++f)
        if (use[f])
          {
            const auto &t = floor.triangles[f];
            for (std::uint32_t k = 0; k + 1 < z.size(); ++k)
              {
                std::array<std::uint32_t, 3> lo, hi;
                for (int i = 0; i < 3; ++i)
                  {
                    lo[i] = static_cast<std::uint32_t>(column[t[i]] + k);
                    hi[i] = lo[i] + 1;
                  }
                detail::split_prism(t, lo, hi, region, m);
              }
          }
    }

    std::vector<double> levels(double z0, double z1, long n)
    {
      std::vector<double> z;
      for (long k = 0; k <= n; ++k)
        z.push_back(k == n ? z1 : z0 + (z1 - z0) * static_cast<double>(k) / static_cast<double>(n));
      return z;
    }
  } // namespace

  TetMesh pipe_mesh(double diameter, double length, double size, double layer, long sides)
  {
    PlanarInput in;
    add_loop(in, polygon(0.5 * diameter, sides));
    in.size = [size](const Point2 &) { return size; };
    const PlanarMesh floor = mesh_planar(in);
    TetMesh          m;
    std::vector<std::int64_t> column(floor.points.size(), -1);
    extrude(floor, std::vector<bool>(floor.triangles.size(), true),
            levels(0, length, std::max(1L, std::lround(length / layer))), column, port, m);
    const double tol = 1e-9 * length;
    detail::orient_and_label(m, [&](const std::array<Point3, 3> &f) -> std::uint8_t {
      const auto on = [&](double z) {
        return std::abs(f[0][2] - z) < tol && std::abs(f[1][2] - z) < tol && std::abs(f[2][2] - z) < tol;
      };
      return on(0) ? inlet : on(length) ? outlet : walls;
    });
    return m;
  }

  namespace
  {
    /// The gap 0 < z < gap over the whole floor, and the port below the
    /// floor triangles `in_port` down to z = -port_length, sharing the
    /// floor's vertices; boundary faces labelled by `label`.
    TetMesh gap_over_port(const PlanarMesh &floor, const std::vector<bool> &in_port, double port_length, double gap,
                          long gap_layers, double port_layer,
                          const std::function<std::uint8_t(const std::array<Point3, 3> &)> &label)
    {
      TetMesh                   m;
      std::vector<std::int64_t> gap_column(floor.points.size(), -1), port_column(floor.points.size(), -1);
      extrude(floor, std::vector<bool>(floor.triangles.size(), true), levels(0, gap, gap_layers), gap_column,
              mesher::gap, m);
      const auto z_port = levels(-port_length, 0, std::max(1L, std::lround(port_length / port_layer)));
      extrude(floor, in_port, z_port, port_column, port, m);
      // Merge the port's top vertices into the gap's bottom ones.
      std::vector<std::uint32_t> merge(m.vertices.size());
      for (std::size_t i = 0; i < merge.size(); ++i)
        merge[i] = static_cast<std::uint32_t>(i);
      for (std::size_t v = 0; v < floor.points.size(); ++v)
        if (port_column[v] >= 0)
          merge[port_column[v] + static_cast<std::int64_t>(z_port.size()) - 1] =
            static_cast<std::uint32_t>(gap_column[v]);
      for (auto &c : m.cells)
        for (auto &v : c)
          v = merge[v];
      detail::orient_and_label(m, label);
      // Drop the vertices the merge left unused.
      std::vector<std::int64_t> index(m.vertices.size(), -1);
      TetMesh                   out;
      for (auto &c : m.cells)
        for (auto &v : c)
          {
            if (index[v] < 0)
              {
                index[v] = static_cast<std::int64_t>(out.vertices.size());
                out.vertices.push_back(m.vertices[v]);
              }
            v = static_cast<std::uint32_t>(index[v]);
          }
      for (auto &f : m.boundary)
        for (auto &v : f.vertices)
          v = static_cast<std::uint32_t>(index[v]);
      out.cells    = std::move(m.cells);
      out.region   = std::move(m.region);
      out.boundary = std::move(m.boundary);
      return out;
    }

    std::array<double, 2> centroid(const PlanarMesh &floor, std::size_t f)
    {
      const auto &t = floor.triangles[f];
      return {(floor.points[t[0]][0] + floor.points[t[1]][0] + floor.points[t[2]][0]) / 3,
              (floor.points[t[0]][1] + floor.points[t[1]][1] + floor.points[t[2]][1]) / 3};
    }
  } // namespace

  TetMesh radial_gap_mesh(double port_diameter, double port_length, double outer_radius, double gap,
                          long gap_layers, double size, double port_layer, long sides)
  {
    const double r1 = 0.5 * port_diameter;
    PlanarInput  in;
    add_loop(in, polygon(outer_radius, 4 * sides));
    add_loop(in, polygon(r1, sides));
    in.size = [=](const Point2 &p) { return size * std::max(1.0, std::hypot(p[0], p[1]) / r1); };
    const PlanarMesh  floor = mesh_planar(in);
    std::vector<bool> in_port(floor.triangles.size());
    const auto        inner = polygon(r1, sides);
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      {
        const auto [cx, cy] = centroid(floor, f);
        bool inside         = true;
        for (std::size_t k = 0; k < inner.size(); ++k)
          {
            const auto &a = inner[k], &b = inner[(k + 1) % inner.size()];
            inside = inside && (b[0] - a[0]) * (cy - a[1]) - (b[1] - a[1]) * (cx - a[0]) >= 0;
          }
        in_port[f] = inside;
      }
    const double tol = 1e-9 * outer_radius;
    // Outlet: faces whose three vertices lie on the outer polygon (radius
    // between its inradius and circumradius).
    const double n4 = 4.0 * static_cast<double>(sides);
    const double R_out = outer_radius * std::sqrt(2 * M_PI / (n4 * std::sin(2 * M_PI / n4)));
    const double r_in  = R_out * std::cos(M_PI / n4) * (1 - 1e-9);
    return gap_over_port(floor, in_port, port_length, gap, gap_layers, port_layer,
                         [&](const std::array<Point3, 3> &f) -> std::uint8_t {
                           bool at_inlet = true, at_rim = true, at_top = true;
                           for (const auto &p : f)
                             {
                               at_inlet = at_inlet && std::abs(p[2] + port_length) < tol;
                               at_rim   = at_rim && p[2] > -tol && std::hypot(p[0], p[1]) >= r_in;
                               at_top   = at_top && std::abs(p[2] - gap) < 1e-9 * gap;
                             }
                           return at_inlet ? inlet : at_rim ? outlet : at_top ? reed : walls;
                         });
  }

  TetMesh slot_gap_mesh(double slot_width, double port_length, double strip_width, double strip_length, double gap,
                        long gap_layers, double size, double port_layer)
  {
    const double s = 0.5 * slot_width, w = 0.5 * strip_width, L = strip_length;
    PlanarInput  in;
    in.points = {{-w, 0}, {-s, 0}, {s, 0}, {w, 0}, {w, L}, {s, L}, {-s, L}, {-w, L}};
    for (std::uint32_t k = 0; k < 8; ++k)
      in.segments.push_back({k, (k + 1) % 8});
    in.segments.push_back({1, 6});
    in.segments.push_back({2, 5});
    in.size                 = [size](const Point2 &) { return size; };
    const PlanarMesh  floor = mesh_planar(in);
    std::vector<bool> in_port(floor.triangles.size());
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      in_port[f] = std::abs(centroid(floor, f)[0]) < s;
    const double tol = 1e-9 * strip_width;
    return gap_over_port(floor, in_port, port_length, gap, gap_layers, port_layer,
                         [&](const std::array<Point3, 3> &f) -> std::uint8_t {
                           bool at_inlet = true, at_side = true, at_top = true;
                           for (const auto &p : f)
                             {
                               at_inlet = at_inlet && std::abs(p[2] + port_length) < tol;
                               at_side  = at_side && p[2] > -tol && std::abs(p[0]) > w - tol;
                               at_top   = at_top && std::abs(p[2] - gap) < 1e-9 * gap;
                             }
                           return at_inlet ? inlet : at_side ? outlet : at_top ? reed : walls;
                         });
  }

  TetMesh disc_half_space_mesh(double radius, double far_radius, double height, double size, double growth,
                               long sides)
  {
    PlanarInput in;
    add_loop(in, polygon(far_radius, 2 * sides));
    add_loop(in, polygon(radius, sides));
    // Finest at the disc's edge, where the potential is singular.
    in.size = [=](const Point2 &p) { return size + growth * std::abs(std::hypot(p[0], p[1]) - radius); };
    const PlanarMesh floor = mesh_planar(in);
    // Levels growing geometrically from `size` at the disc to `height`.
    std::vector<double> z{0.0};
    for (double dz = size; z.back() < height; dz *= 1 + growth)
      z.push_back(std::min(height, z.back() + dz));
    TetMesh                   m;
    std::vector<std::int64_t> column(floor.points.size(), -1);
    extrude(floor, std::vector<bool>(floor.triangles.size(), true), z, column, bulk, m);
    const auto   disc = polygon(radius, sides);
    const double tol  = 1e-9 * far_radius;
    detail::orient_and_label(m, [&](const std::array<Point3, 3> &f) -> std::uint8_t {
      bool   on_floor = true;
      double cx = 0, cy = 0;
      for (const auto &p : f)
        {
          on_floor = on_floor && std::abs(p[2]) < tol;
          cx += p[0] / 3;
          cy += p[1] / 3;
        }
      if (!on_floor)
        return outlet;
      bool inside = true;
      for (std::size_t k = 0; k < disc.size(); ++k)
        {
          const auto &a = disc[k], &b = disc[(k + 1) % disc.size()];
          inside = inside && (b[0] - a[0]) * (cy - a[1]) - (b[1] - a[1]) * (cx - a[0]) >= 0;
        }
      return inside ? reed : outlet;
    });
    return m;
  }
} // namespace rectify::mesher
