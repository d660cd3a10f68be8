#include <algorithm>
#include <cmath>

#include "mesher/layout.h"

namespace rectify::mesher::detail
{
  PortPolygon Layout::port_polygon() const
  {
    const double c = g.port_center_x_m;
    const auto  &st = shape.stations();
    // The stations that cross the circle, and the arcs' subdivisions, fixed
    // at a radius slightly above r so that the area is continuous in R.
    std::vector<std::size_t> crossing;
    for (std::size_t j = 0; j < st.size(); ++j)
      if (std::abs(st[j] - c) < r * 1.001)
        crossing.push_back(j);
    const double max_step = 2 * M_PI / static_cast<double>(n_port);
    struct Angle { double theta; std::size_t station; };
    auto crossing_angles = [&](double R) {
      std::vector<Angle> a;
      for (auto j : crossing)
        {
          const double t = std::acos(std::clamp((st[j] - c) / R, -1.0, 1.0));
          a.push_back({t, j});
          a.push_back({2 * M_PI - t, j});
        }
      std::sort(a.begin(), a.end(), [](const Angle &x, const Angle &y) { return x.theta < y.theta; });
      return a;
    };
    std::vector<std::size_t> n_sub; // subdivisions of the arc after each crossing
    {
      const auto a = crossing_angles(r * 1.001);
      for (std::size_t k = 0; k < a.size(); ++k)
        {
          const double next = k + 1 < a.size() ? a[k + 1].theta : a[0].theta + 2 * M_PI;
          n_sub.push_back(static_cast<std::size_t>(std::ceil((next - a[k].theta) / max_step - 1e-9)));
        }
    }
    auto build = [&](double R) {
      PortPolygon poly;
      poly.R       = R;
      const auto a = crossing_angles(R);
      for (std::size_t k = 0; k < a.size(); ++k)
        {
          poly.points.push_back({st[a[k].station], R * std::sin(a[k].theta)});
          poly.station.push_back(a[k].station);
          const double next = k + 1 < a.size() ? a[k + 1].theta : a[0].theta + 2 * M_PI;
          const auto   n    = std::max<std::size_t>(1, n_sub[k]);
          for (std::size_t i = 1; i < n; ++i)
            {
              const double t = a[k].theta + (next - a[k].theta) * static_cast<double>(i) / static_cast<double>(n);
              poly.points.push_back({c + R * std::cos(t), R * std::sin(t)});
              poly.station.push_back(static_cast<std::size_t>(-1));
            }
        }
      return poly;
    };
    auto area = [](const PortPolygon &p) {
      double s = 0;
      for (std::size_t k = 0; k < p.points.size(); ++k)
        {
          const auto &u = p.points[k], &v = p.points[(k + 1) % p.points.size()];
          s += u[0] * v[1] - u[1] * v[0];
        }
      return 0.5 * s;
    };
    const double target = M_PI * r * r;
    double       lo = r, hi = 1.2 * r;
    for (int it = 0; it < 200 && hi - lo > 1e-16 * r; ++it)
      {
        const double mid = 0.5 * (lo + hi);
        (area(build(mid)) < target ? lo : hi) = mid;
      }
    PortPolygon poly = build(0.5 * (lo + hi));
    poly.inradius = poly.R;
    for (std::size_t k = 0; k < poly.points.size(); ++k)
      {
        const auto  &u = poly.points[k], &v = poly.points[(k + 1) % poly.points.size()];
        const double len = std::hypot(v[0] - u[0], v[1] - u[1]);
        const double d = std::abs((v[0] - u[0]) * (u[1]) - (v[1] - u[1]) * (u[0] - c)) / len;
        poly.inradius = std::min(poly.inradius, d);
      }
    return poly;
  }

  bool PortPolygon::contains(double x, double y) const
  {
    for (std::size_t k = 0; k < points.size(); ++k)
      {
        const auto &a = points[k], &b = points[(k + 1) % points.size()];
        if ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) < 0)
          return false;
      }
    return true;
  }

    /// The floor triangulation: the outer rectangle, the reed's edges and
    /// stations, the cut-off line, the port polygon.
  PlanarMesh mesh_floor(const Layout &lay, const PortPolygon &poly)
    {
      PlanarInput in;
      auto add = [&](double x, double y) {
        in.points.push_back({x, y});
        return static_cast<std::uint32_t>(in.points.size() - 1);
      };
      auto seg = [&](std::uint32_t a, std::uint32_t b) { in.segments.push_back({a, b}); };
      const auto  &st = lay.shape.stations();
      const double hw = 0.5 * lay.W, hp = 0.5 * lay.Wp;
      std::vector<std::uint32_t> lower, upper;
      for (double s : st)
        {
          lower.push_back(add(s, -hw));
          upper.push_back(add(s, hw));
        }
      const auto c0 = add(0, -hp), c1 = add(lay.Lp, -hp), c2 = add(lay.Lp, hp), c3 = add(0, hp);
      seg(c0, c1), seg(c1, c2), seg(c2, c3), seg(c3, upper[0]), seg(upper[0], lower[0]),
        seg(lower[0], c0);
      const auto first = static_cast<std::uint32_t>(in.points.size());
      for (const auto &p : poly.points)
        add(p[0], p[1]);
      const auto n_poly = static_cast<std::uint32_t>(poly.points.size());
      for (std::uint32_t k = 0; k < n_poly; ++k)
        seg(first + k, first + (k + 1) % n_poly);
      for (std::size_t j = 1; j < st.size(); ++j)
        {
          seg(lower[j - 1], lower[j]);
          seg(upper[j - 1], upper[j]);
          // The station line (the last one is the tip), through the port's
          // polygon vertices on it, from y = -W/2 to W/2.
          std::vector<std::pair<double, std::uint32_t>> on_line{{-hw, lower[j]}, {hw, upper[j]}};
          for (std::uint32_t k = 0; k < n_poly; ++k)
            if (poly.station[k] == j)
              on_line.emplace_back(poly.points[k][1], first + k);
          std::sort(on_line.begin(), on_line.end());
          for (std::size_t k = 1; k < on_line.size(); ++k)
            seg(on_line[k - 1].second, on_line[k].second);
        }
      in.size          = [&lay](const Point2 &p) { return lay.size_at(p); };
      in.min_angle_deg = lay.s.min_angle_deg;
      PlanarMesh floor = mesh_planar(in);

      // Points CGAL put on a constrained line: snap them exactly onto it.
      const double tol = 1e-10 * lay.Lp;
      for (std::size_t i = 0; i < floor.points.size(); ++i)
        {
          if (!floor.on_segment[i])
            continue;
          auto &p    = floor.points[i];
          auto  snap = [tol](double &v, double target) {
            if (std::abs(v - target) < tol)
              v = target;
          };
          snap(p[0], 0.0), snap(p[0], lay.Lp), snap(p[1], -hp), snap(p[1], hp);
          if (p[0] <= lay.L + tol)
            snap(p[1], -hw), snap(p[1], hw);
          if (std::abs(p[1]) <= hw + tol)
            {
              const auto it = std::lower_bound(st.begin(), st.end(), p[0] - tol);
              if (it != st.end())
                snap(p[0], *it);
            }
        }
      return floor;
    }

  std::vector<FloorPart> classify_floor(const Layout &lay, const PlanarMesh &floor, const PortPolygon &port)
  {
    std::vector<FloorPart> parts(floor.triangles.size());
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      {
        const auto  &t  = floor.triangles[f];
        const double cx = (floor.points[t[0]][0] + floor.points[t[1]][0] + floor.points[t[2]][0]) / 3;
        const double cy = (floor.points[t[0]][1] + floor.points[t[1]][1] + floor.points[t[2]][1]) / 3;
        if (cx < lay.L && std::abs(cy) < 0.5 * lay.W)
          parts[f] = port.contains(cx, cy) ? FloorPart::port
                     : cx < lay.x_closed   ? FloorPart::closed
                                           : FloorPart::open;
        else
          parts[f] = FloorPart::outside;
      }
    return parts;
  }

    double min_angle_deg(const PlanarMesh &m)
    {
      double smallest = 180;
      for (const auto &t : m.triangles)
        for (int k = 0; k < 3; ++k)
          {
            const auto  &a = m.points[t[k]], &b = m.points[t[(k + 1) % 3]], &c = m.points[t[(k + 2) % 3]];
            const double ux = b[0] - a[0], uy = b[1] - a[1], vx = c[0] - a[0], vy = c[1] - a[1];
            const double angle = std::atan2(std::abs(ux * vy - uy * vx), ux * vx + uy * vy);
            smallest           = std::min(smallest, angle * 180 / M_PI);
          }
      return smallest;
    }
} // namespace rectify::mesher::detail
