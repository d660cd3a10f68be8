#include <algorithm>
#include <cmath>
#include <tuple>

#include "mesher/layout.h"
#include "mesher/mesher.h"

namespace rectify::mesher::detail
{
  namespace
  {
    /// A circular port's mouth, centre (cx, cy): a vertex where each station
    /// line crosses the circle, the arcs between subdivided to at most
    /// 2 pi / n_port, the radius chosen for the area pi r^2.
    PortPolygon circle_polygon(const Layout &lay, double cx, double cy, double r)
    {
      const double c  = cx;
      const auto  &st = lay.shape.stations();
      // The stations that cross the circle, and the arcs' subdivisions, fixed
      // at a radius slightly above r so that the area is continuous in R.
      std::vector<std::size_t> crossing;
      for (std::size_t j = 0; j < st.size(); ++j)
        if (std::abs(st[j] - c) < r * 1.001)
          crossing.push_back(j);
      const auto   n_port   = lay.s.port_segments > 0
                                ? static_cast<std::size_t>(lay.s.port_segments)
                                : static_cast<std::size_t>(std::max(16.0, 4 * std::ceil(2 * M_PI * r / lay.s.size_reed_m / 4)));
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
            poly.points.push_back({st[a[k].station], cy + R * std::sin(a[k].theta)});
            poly.station.push_back(a[k].station);
            const double next = k + 1 < a.size() ? a[k + 1].theta : a[0].theta + 2 * M_PI;
            const auto   n    = std::max<std::size_t>(1, n_sub[k]);
            for (std::size_t i = 1; i < n; ++i)
              {
                const double t = a[k].theta + (next - a[k].theta) * static_cast<double>(i) / static_cast<double>(n);
                poly.points.push_back({c + R * std::cos(t), cy + R * std::sin(t)});
                poly.station.push_back(static_cast<std::size_t>(-1));
              }
          }
        return poly;
      };
      const double target = M_PI * r * r;
      double       lo = r, hi = 1.2 * r;
      for (int it = 0; it < 200 && hi - lo > 1e-16 * r; ++it)
        {
          const double mid = 0.5 * (lo + hi);
          (build(mid).area() < target ? lo : hi) = mid;
        }
      PortPolygon poly = build(0.5 * (lo + hi));
      poly.inradius = poly.R;
      for (std::size_t k = 0; k < poly.points.size(); ++k)
        {
          const auto  &u = poly.points[k], &v = poly.points[(k + 1) % poly.points.size()];
          const double len = std::hypot(v[0] - u[0], v[1] - u[1]);
          const double d = std::abs((v[0] - u[0]) * (u[1] - cy) - (v[1] - u[1]) * (u[0] - c)) / len;
          poly.inradius = std::min(poly.inradius, d);
        }
      return poly;
    }

    /// A polygon's corners, and a vertex wherever a station line crosses an
    /// edge; per point, the station it lies on (or npos). Corners within
    /// 1e-12 Lp of a station are put on it.
    struct OnStations
    {
      std::vector<Point2>      points;
      std::vector<std::size_t> station;
    };

    OnStations on_stations(const Layout &lay, const geometry::Polygon &polygon)
    {
      const auto  &st   = lay.shape.stations();
      const auto   npos = static_cast<std::size_t>(-1);
      const double tol  = 1e-12 * lay.Lp;
      OnStations   out;
      for (std::size_t i = 0; i < polygon.size(); ++i)
        {
          const auto &a = polygon[i], &b = polygon[(i + 1) % polygon.size()];
          std::size_t on = npos;
          for (std::size_t j = 0; j < st.size(); ++j)
            if (std::abs(a[0] - st[j]) <= tol)
              on = j;
          out.points.push_back({on == npos ? a[0] : st[on], a[1]});
          out.station.push_back(on);
          // stations strictly between a and b, in the order met from a
          std::vector<std::size_t> between;
          for (std::size_t j = 0; j < st.size(); ++j)
            if (std::min(a[0], b[0]) + tol < st[j] && st[j] < std::max(a[0], b[0]) - tol)
              between.push_back(j);
          if (b[0] < a[0])
            std::reverse(between.begin(), between.end());
          for (const auto j : between)
            {
              out.points.push_back({st[j], a[1] + (st[j] - a[0]) / (b[0] - a[0]) * (b[1] - a[1])});
              out.station.push_back(j);
            }
        }
      return out;
    }
  } // namespace

  std::vector<PortPolygon> Layout::port_polygons() const
  {
    std::vector<PortPolygon> out;
    for (const auto &port : ports)
      {
        PortPolygon poly;
        if (port.circular)
          poly = circle_polygon(*this, port.center_m[0], port.center_m[1], 0.5 * port.diameter_m);
        else
          {
            auto refined = on_stations(*this, port.outline_m);
            poly.points  = std::move(refined.points);
            poly.station = std::move(refined.station);
          }
        poly.length = port.length_m;
        out.push_back(std::move(poly));
      }
    return out;
  }

  double PortPolygon::area() const
  {
    double s = 0;
    for (std::size_t k = 0; k < points.size(); ++k)
      {
        const auto &u = points[k], &v = points[(k + 1) % points.size()];
        s += u[0] * v[1] - u[1] * v[0];
      }
    return 0.5 * s;
  }

  bool PortPolygon::contains(double x, double y) const
  {
    return geometry::side_of(points, {x, y}) == geometry::Side::inside;
  }

  bool PortPolygon::on_edge(double x, double y, double tol) const
  {
    return geometry::distance_to_boundary(points, {x, y}) <= tol;
  }

  /// The floor triangulation: the pocket's floor; the reed's outline with a
  /// line across it at every station (through the ports' vertices on it),
  /// so that the layered gap follows the sampled shape exactly; the ports.
  PlanarMesh mesh_floor(const Layout &lay, const std::vector<PortPolygon> &ports)
  {
    PlanarInput in;
    auto add = [&](double x, double y) {
      in.points.push_back({x, y});
      return static_cast<std::uint32_t>(in.points.size() - 1);
    };
    auto seg = [&](std::uint32_t a, std::uint32_t b) { in.segments.push_back({a, b}); };
    const auto  &st   = lay.shape.stations();
    const auto   npos = static_cast<std::size_t>(-1);
    const double hp   = 0.5 * lay.Wp;
    // The outline's points, station by station in increasing y (the
    // shorthand's rectangle: (s, -W/2), (s, W/2) for each station), then
    // those between stations.
    const OnStations outline = on_stations(lay, lay.outline);
    std::vector<std::uint32_t> id(outline.points.size());
    std::vector<std::vector<std::pair<double, std::uint32_t>>> on_station(st.size());
    {
      std::vector<std::size_t> order(outline.points.size());
      for (std::size_t k = 0; k < order.size(); ++k)
        order[k] = k;
      std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        const auto sa = outline.station[a], sb = outline.station[b];
        if (sa != sb)
          return sa < sb; // npos (between stations) last
        return sa != npos && outline.points[a][1] < outline.points[b][1];
      });
      for (const auto k : order)
        {
          id[k] = add(outline.points[k][0], outline.points[k][1]);
          if (outline.station[k] != npos)
            on_station[outline.station[k]].emplace_back(outline.points[k][1], id[k]);
        }
    }
    // The clamp line: the outline's edge on station 0 (x = 0).
    if (on_station[0].size() != 2)
      throw MeshError("internal: the reed's outline meets the clamp line x = 0 at " +
                      std::to_string(on_station[0].size()) + " points, not its two ends");
    std::sort(on_station[0].begin(), on_station[0].end());
    const auto clamp_lo = on_station[0].front().second, clamp_hi = on_station[0].back().second;
    const auto c0 = add(0, -hp), c1 = add(lay.Lp, -hp), c2 = add(lay.Lp, hp), c3 = add(0, hp);
    seg(c0, c1), seg(c1, c2), seg(c2, c3), seg(c3, clamp_hi), seg(clamp_hi, clamp_lo), seg(clamp_lo, c0);
    std::vector<std::vector<std::pair<double, std::uint32_t>>> port_on_station(st.size());
    for (const auto &poly : ports)
      {
        const auto first  = static_cast<std::uint32_t>(in.points.size());
        const auto n_poly = static_cast<std::uint32_t>(poly.points.size());
        for (const auto &p : poly.points)
          add(p[0], p[1]);
        for (std::uint32_t k = 0; k < n_poly; ++k)
          {
            seg(first + k, first + (k + 1) % n_poly);
            if (poly.station[k] != npos)
              port_on_station[poly.station[k]].emplace_back(poly.points[k][1], first + k);
          }
      }
    // The outline's edges between stations (those along a station line are
    // drawn with it), bucketed by the station interval they lie in, lower
    // side first, each from smaller to larger x.
    std::vector<std::vector<std::tuple<double, std::uint32_t, std::uint32_t>>> pieces(st.size());
    const std::size_t n_out = outline.points.size();
    for (std::size_t k = 0; k < n_out; ++k)
      {
        const std::size_t next = (k + 1) % n_out;
        if (outline.station[k] != npos && outline.station[k] == outline.station[next])
          continue; // along a station line (the clamp, a square tip)
        const auto  &a = outline.points[k], &b = outline.points[next];
        const double xm = 0.5 * (a[0] + b[0]);
        std::size_t  j  = static_cast<std::size_t>(std::upper_bound(st.begin(), st.end(), xm) - st.begin());
        j               = std::clamp<std::size_t>(j, 1, st.size() - 1);
        const bool forward = a[0] <= b[0];
        pieces[j].emplace_back(0.5 * (a[1] + b[1]), forward ? id[k] : id[next], forward ? id[next] : id[k]);
      }
    for (std::size_t j = 1; j < st.size(); ++j)
      {
        std::sort(pieces[j].begin(), pieces[j].end());
        for (const auto &[y, a, b] : pieces[j])
          seg(a, b);
        // The station line across the reed, through the ports' vertices on
        // it: between consecutive points where it lies inside the reed (or
        // along its edge: a square tip).
        auto line = on_station[j];
        line.insert(line.end(), port_on_station[j].begin(), port_on_station[j].end());
        std::sort(line.begin(), line.end());
        for (std::size_t k = 1; k < line.size(); ++k)
          {
            const double ym = 0.5 * (line[k - 1].first + line[k].first);
            if (geometry::side_of(lay.outline, {st[j], ym}) != geometry::Side::outside ||
                geometry::distance_to_boundary(lay.outline, {st[j], ym}) <= 1e-12 * lay.Lp)
              seg(line[k - 1].second, line[k].second);
          }
      }
    in.size          = [&lay](const Point2 &p) { return lay.size_at(p); };
    in.min_angle_deg = lay.s.min_angle_deg;
    PlanarMesh floor = mesh_planar(in);

    // Points CGAL put on a constrained line: snap them exactly onto it.
    const double tol = 1e-10 * lay.Lp;
    const double hw  = 0.5 * lay.W;
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
        if (lay.rectangle && p[0] <= lay.L + tol)
          snap(p[1], -hw), snap(p[1], hw);
        const bool near_reed = lay.rectangle ? std::abs(p[1]) <= hw + tol : p[0] <= lay.L + tol;
        if (near_reed)
          {
            const auto it = std::lower_bound(st.begin(), st.end(), p[0] - tol);
            if (it != st.end())
              snap(p[0], *it);
          }
      }
    return floor;
  }

  std::vector<FloorPart> classify_floor(const Layout &lay, const PlanarMesh &floor,
                                        const std::vector<PortPolygon> &ports, std::vector<int> &port_of)
  {
    std::vector<FloorPart> parts(floor.triangles.size());
    port_of.assign(floor.triangles.size(), -1);
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      {
        const auto  &t  = floor.triangles[f];
        const double cx = (floor.points[t[0]][0] + floor.points[t[1]][0] + floor.points[t[2]][0]) / 3;
        const double cy = (floor.points[t[0]][1] + floor.points[t[1]][1] + floor.points[t[2]][1]) / 3;
        const bool   under = lay.rectangle ? cx < lay.L && std::abs(cy) < 0.5 * lay.W
                                           : geometry::side_of(lay.outline, {cx, cy}) == geometry::Side::inside;
        if (!under)
          {
            parts[f] = FloorPart::outside;
            continue;
          }
        for (std::size_t k = 0; k < ports.size() && port_of[f] < 0; ++k)
          if (ports[k].contains(cx, cy))
            port_of[f] = static_cast<int>(k);
        parts[f] = port_of[f] >= 0 ? FloorPart::port : cx < lay.x_closed ? FloorPart::closed : FloorPart::open;
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
