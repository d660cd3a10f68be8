#include "mesher/mesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "mesher/bulk_tetgen.h"
#include "mesher/planar.h"

namespace rectify::mesher
{
  namespace
  {
    using Clock = std::chrono::steady_clock;

    enum Tag : std::uint8_t
    {
      tag_gap = gap, tag_slab = slab, tag_port = port, tag_bulk = bulk,
      tag_reed_solid = 10,  ///< inside the reed: removed, its faces are the reed's surface
      tag_closed_solid = 11 ///< the gap under the reed thinner than the cut-off: removed
    };
    bool is_fluid(std::uint8_t tag) { return tag < n_regions; }

    /// The domain's dimensions at one opening, and the layer structure.
    struct Layout
    {
      const ValveGeometry &g;
      const MeshSettings  &s;
      SampledShape         shape;
      double               opening;
      double               L, W, t, Lp, Wp, Hp, ell, r;
      std::size_t          n_port = 0;
      std::size_t          j_closed = 0;
      double               x_closed = 0, h_cut = 0;
      long                 Ng, Nr, Na, N;

      Layout(const MeshParameters &p, double x_tip)
        : g(p.geometry), s(p.settings), shape(p.reed_shape(), p.settings.station_spacing_m),
          opening(x_tip), L(g.reed_length_m), W(g.reed_width_m), t(g.reed_thickness_m),
          Lp(g.pocket_length_m), Wp(g.pocket_width_m), Hp(g.pocket_height_m), ell(g.port_length_m),
          r(0.5 * g.port_diameter_m), Ng(s.gap_layers), Nr(s.reed_layers), Na(s.above_layers),
          N(Ng + Nr + Na)
      {
        n_port = s.port_segments > 0 ? static_cast<std::size_t>(s.port_segments)
                                     : static_cast<std::size_t>(std::max(
                                         16.0, 4 * std::ceil(2 * M_PI * r / s.size_reed_m / 4)));
        const auto &phi = shape.values();
        j_closed        = 1;
        while (j_closed + 1 < phi.size() && phi[j_closed] < s.gap_cutoff_ratio)
          ++j_closed;
        x_closed = shape.stations()[j_closed];
        h_cut    = opening * phi[j_closed];
      }

      double sampled_h(double x) const { return opening * shape(std::min(x, L)); }
      double slab_top(double x) const { return sampled_h(x) + t + s.slab_margin_m; }

      /// Distance from (x, y) to the reed's footprint [0, L] x [-W/2, W/2].
      double distance_to_reed(double x, double y) const
      {
        const double dx = std::max(0.0, x - L), dy = std::max(0.0, std::abs(y) - 0.5 * W);
        return std::hypot(dx, dy);
      }

      /// z of level m (0..N) in the column at floor point (x, y).
      double level(double x, double y, long m) const
      {
        const double h  = sampled_h(x);
        const double hb = std::max(h, h_cut);
        const double ht = h + t;
        const double zs = ht + s.slab_margin_m;
        double       reed_pattern;
        if (m <= Ng)
          reed_pattern = hb * static_cast<double>(m) / static_cast<double>(Ng);
        else if (m <= Ng + Nr)
          reed_pattern = hb + (ht - hb) * static_cast<double>(m - Ng) / static_cast<double>(Nr);
        else
          reed_pattern = ht + s.slab_margin_m * static_cast<double>(m - Ng - Nr) / static_cast<double>(Na);
        if (m == N)
          return zs;
        const double uniform = zs * static_cast<double>(m) / static_cast<double>(N);
        const double u = std::clamp(distance_to_reed(x, y) / s.blend_distance_m, 0.0, 1.0);
        const double w = u * u * (3 - 2 * u);
        return (1 - w) * reed_pattern + w * uniform;
      }

      double size_at(const Point2 &p) const
      {
        const double d = distance_to_reed(p[0], p[1]);
        return d == 0 ? s.size_reed_m : std::min(s.size_far_m, s.size_reed_m + s.size_growth * d);
      }

      /// The port's polygon: a vertex wherever a station line crosses the
      /// circle (so station lines end on it), more vertices where those are
      /// further apart than 2 pi / n_port, and the radius chosen so that the
      /// polygon's area is pi r^2 exactly. Counter-clockwise.
      struct Polygon
      {
        std::vector<Point2>      points;
        std::vector<std::size_t> station; ///< per point: station index, or npos
        double                   R = 0;   ///< circumradius
        double                   inradius = 0;
      };

      Polygon port_polygon() const
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
          Polygon poly;
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
        auto area = [](const Polygon &p) {
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
        Polygon poly = build(0.5 * (lo + hi));
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
    };

    /// The floor triangulation: the outer rectangle, the reed's edges and
    /// stations, the cut-off line, the port polygon.
    PlanarMesh mesh_floor(const Layout &lay)
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
      const auto poly  = lay.port_polygon();
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

    struct FaceRecord
    {
      std::array<std::uint32_t, 3> key;
      std::uint32_t                cell;
      std::uint32_t                opposite;
    };

    std::string where(const Point3 &p)
    {
      char buf[128];
      std::snprintf(buf, sizeof(buf), "(%.6g, %.6g, %.6g) mm", p[0] * 1e3, p[1] * 1e3, p[2] * 1e3);
      return buf;
    }
  } // namespace

  ValveMesh mesh_valve(const MeshParameters &parameters, double opening, bool verbose)
  {
    const auto start = Clock::now();
    auto       stage = start;
    ValveMesh  result;
    MeshInfo  &info = result.info;
    auto       lap  = [&](const std::string &name) {
      const auto now = Clock::now();
      info.timings_s.emplace_back(name, std::chrono::duration<double>(now - stage).count());
      if (verbose)
        std::fprintf(stderr, "  %-28s %.2f s\n", name.c_str(), info.timings_s.back().second);
      stage = now;
    };

    const auto &g = parameters.geometry;
    const auto &s = parameters.settings;
    if (!std::isfinite(opening) || !(opening > 0))
      throw InputError("tip opening = " + format_number(opening) + " m: must be positive");
    if (opening + g.reed_thickness_m >= g.pocket_height_m)
      throw InputError("tip opening = " + format_number(opening) +
                       " m would push the reed through the pocket ceiling: its tip's top at " +
                       format_number(opening + g.reed_thickness_m) +
                       " m, [geometry] pocket_height_m = " + format_number(g.pocket_height_m));
    if (opening + g.reed_thickness_m + 2 * s.slab_margin_m > g.pocket_height_m)
      throw InputError("tip opening = " + format_number(opening) + " m leaves " +
                       format_number(g.pocket_height_m - opening - g.reed_thickness_m) +
                       " m above the reed's tip; the mesher needs 2 x [mesh] slab_margin_m = " +
                       format_number(2 * s.slab_margin_m) + " m there (lower slab_margin_m)");

    const Layout lay(parameters, opening);
    if (lay.h_cut >= 0.9 * lay.t)
      throw InputError("[mesh] gap_cutoff_ratio = " + format_number(s.gap_cutoff_ratio) +
                       ": at tip opening " + format_number(opening) + " m the cut-off gap (" +
                       format_number(lay.h_cut) + " m) is not thinner than the reed; lower it");
    if (g.port_center_x_m - 1.01 * lay.r <= lay.x_closed + 0.5 * s.size_reed_m)
      throw InputError("[mesh] gap_cutoff_ratio = " + format_number(s.gap_cutoff_ratio) +
                       ": the gap treated as closed (up to " + format_number(lay.x_closed) +
                       " m from the clamp line) reaches the port; lower it");

    // 1. The floor.
    const PlanarMesh floor = mesh_floor(lay);
    const auto       nf    = static_cast<std::uint32_t>(floor.points.size());
    info.n_floor_triangles = floor.triangles.size();
    lap("floor triangulation (CGAL)");

    const auto   polygon = lay.port_polygon();
    const auto  &poly    = polygon.points;
    const double hw      = 0.5 * lay.W;
    auto         in_port = [&](double x, double y) {
      for (std::size_t k = 0; k < poly.size(); ++k)
        {
          const auto &a = poly[k], &b = poly[(k + 1) % poly.size()];
          if ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) < 0)
            return false;
        }
      return true;
    };
    enum class Where { outside, open, closed, port };
    std::vector<Where> where_tri(floor.triangles.size());
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      {
        const auto  &t  = floor.triangles[f];
        const double cx = (floor.points[t[0]][0] + floor.points[t[1]][0] + floor.points[t[2]][0]) / 3;
        const double cy = (floor.points[t[0]][1] + floor.points[t[1]][1] + floor.points[t[2]][1]) / 3;
        if (cx < lay.L && std::abs(cy) < hw)
          where_tri[f] = in_port(cx, cy) ? Where::port : cx < lay.x_closed ? Where::closed : Where::open;
        else
          where_tri[f] = Where::outside;
      }

    // 2. The layered slab: vertex (floor point i, level m) is i * (N + 1) + m.
    TetMesh     all;
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
            if (where_tri[f] != Where::outside)
              {
                if (m < lay.Ng)
                  tag = where_tri[f] == Where::closed ? tag_closed_solid : tag_gap;
                else if (m < lay.Ng + lay.Nr)
                  tag = tag_reed_solid;
              }
            const auto mm = static_cast<std::uint32_t>(m);
            split_prism(t, {t[0] * N1 + mm, t[1] * N1 + mm, t[2] * N1 + mm},
                        {t[0] * N1 + mm + 1, t[1] * N1 + mm + 1, t[2] * N1 + mm + 1}, tag, all);
          }
      }
    lap("layered slab");

    // 3. The port, extruded downwards from the floor triangles inside it.
    const auto n_port_layers =
      static_cast<std::uint32_t>(std::max(1.0, std::ceil(lay.ell / s.port_layer_m - 1e-9)));
    std::vector<std::int64_t> port_column(nf, -1); // first vertex of the column below the floor
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      if (where_tri[f] == Where::port)
        for (auto v : floor.triangles[f])
          if (port_column[v] < 0)
            {
              port_column[v] = static_cast<std::int64_t>(all.vertices.size());
              for (std::uint32_t k = 1; k <= n_port_layers; ++k)
                all.vertices.push_back({floor.points[v][0], floor.points[v][1],
                                        k == n_port_layers ? -lay.ell : -lay.ell * k / n_port_layers});
            }
    auto port_vertex = [&](std::uint32_t v, std::uint32_t k) {
      return k == 0 ? v * N1 : static_cast<std::uint32_t>(port_column[v] + k - 1);
    };
    for (std::size_t f = 0; f < floor.triangles.size(); ++f)
      if (where_tri[f] == Where::port)
        {
          const auto &t = floor.triangles[f];
          for (std::uint32_t k = 0; k < n_port_layers; ++k)
            split_prism(t, {port_vertex(t[0], k), port_vertex(t[1], k), port_vertex(t[2], k)},
                        {port_vertex(t[0], k + 1), port_vertex(t[1], k + 1), port_vertex(t[2], k + 1)},
                        tag_port, all);
        }
    lap("port extrusion");

    // 4. The pocket above the slab: its closed surface is the slab's top
    //    (the floor triangulation lifted), four walls and the ceiling.
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
    lap("pocket surface (CGAL)");

    const TetgenResult tg = tetrahedralize_closed_surface(
      surface_points, surface_triangles,
      {s.tetgen_radius_edge_ratio, s.tetgen_min_dihedral_deg, s.tetgen_max_volume_m3});
    info.tetgen_switches = tg.switches;
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
    info.n_bulk_cells = tg.cells.size();
    lap("pocket tetrahedra (TetGen)");

    // 5. Orientation, faces and boundary ids.
    double min_relative = 1e300;
    for (std::size_t c = 0; c < all.cells.size(); ++c)
      {
        auto        &v  = all.cells[c];
        double       vol = cell_volume(all, c);
        if (vol < 0)
          {
            std::swap(v[2], v[3]);
            vol = -vol;
          }
        double longest = 0;
        for (int i = 0; i < 4; ++i)
          for (int j = i + 1; j < 4; ++j)
            {
              const auto &p = all.vertices[v[i]], &q = all.vertices[v[j]];
              longest = std::max(longest, std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
            }
        const double rel = vol / (longest * longest * longest);
        if (!(rel > 1e-13))
          throw MeshError("a degenerate or inverted cell (" + region_name(all.region[c]) + ") at " +
                          where(all.vertices[v[0]]) + ": volume / edge^3 = " + format_number(rel));
        min_relative = std::min(min_relative, rel);
      }

    std::vector<FaceRecord> faces;
    faces.reserve(all.cells.size() * 4);
    for (std::uint32_t c = 0; c < all.cells.size(); ++c)
      for (int k = 0; k < 4; ++k)
        {
          std::array<std::uint32_t, 3> key;
          int                          n = 0;
          for (int j = 0; j < 4; ++j)
            if (j != k)
              key[n++] = all.cells[c][j];
          std::sort(key.begin(), key.end());
          faces.push_back({key, c, all.cells[c][k]});
        }
    std::sort(faces.begin(), faces.end(),
              [](const FaceRecord &a, const FaceRecord &b) { return a.key < b.key; });

    const double tol  = 1e-9 * lay.Lp;
    auto         on   = [&](const std::array<std::uint32_t, 3> &f, int axis, double value) {
      for (auto v : f)
        if (std::abs(all.vertices[v][axis] - value) > tol)
          return false;
      return true;
    };
    const int    outlet_axis  = g.outlet_face == "ceiling" ? 2 : g.outlet_face == "x-max" ? 0 : 1;
    const double outlet_value = g.outlet_face == "ceiling" ? lay.Hp
                                : g.outlet_face == "x-max" ? lay.Lp
                                : g.outlet_face == "y-min" ? -hp
                                                           : hp;
    const double r_in = polygon.inradius, r_out = polygon.R;
    auto on_port_side = [&](const std::array<std::uint32_t, 3> &f) {
      for (auto v : f)
        {
          const auto  &p = all.vertices[v];
          const double d = std::hypot(p[0] - g.port_center_x_m, p[1]);
          if (p[2] > tol || p[2] < -lay.ell - tol || d < r_in * (1 - 1e-9) || d > r_out * (1 + 1e-9))
            return false;
        }
      return true;
    };
    auto classify_outer = [&](const std::array<std::uint32_t, 3> &f) -> std::uint8_t {
      if (on(f, 2, -lay.ell))
        return inlet;
      if (on(f, outlet_axis, outlet_value))
        return outlet;
      if (on(f, 0, 0) || on(f, 0, lay.Lp) || on(f, 1, -hp) || on(f, 1, hp) || on(f, 2, lay.Hp) ||
          on(f, 2, 0) || on_port_side(f))
        return walls;
      const auto &p = all.vertices[f[0]];
      throw MeshError("the mesh does not conform: a boundary face inside the domain near " + where(p) +
                      " (TetGen changed the slab's top surface?)");
    };

    std::vector<BoundaryFace> boundary;
    for (std::size_t i = 0; i < faces.size();)
      {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j].key == faces[i].key)
          ++j;
        if (j - i > 2)
          throw MeshError("the mesh does not conform: a face shared by " + std::to_string(j - i) +
                          " cells near " + where(all.vertices[faces[i].key[0]]));
        const FaceRecord *fluid_side = nullptr;
        std::uint8_t      id         = 0;
        if (j - i == 1)
          {
            if (is_fluid(all.region[faces[i].cell]))
              {
                fluid_side = &faces[i];
                id         = classify_outer(faces[i].key);
              }
          }
        else
          {
            const bool f0 = is_fluid(all.region[faces[i].cell]);
            const bool f1 = is_fluid(all.region[faces[i + 1].cell]);
            if (f0 != f1)
              {
                fluid_side = f0 ? &faces[i] : &faces[i + 1];
                const auto other = all.region[(f0 ? faces[i + 1] : faces[i]).cell];
                id = other == tag_reed_solid ? reed : walls;
              }
          }
        if (fluid_side)
          {
            auto        key = fluid_side->key;
            const auto &o   = all.vertices[fluid_side->opposite];
            if (signed_volume(all.vertices[key[0]], all.vertices[key[1]], all.vertices[key[2]], o) > 0)
              std::swap(key[1], key[2]);
            boundary.push_back({key, id});
          }
        i = j;
      }
    lap("orientation and boundary ids");

    // 6. Keep the fluid cells and the vertices they use.
    std::vector<std::int64_t> new_index(all.vertices.size(), -1);
    TetMesh                  &mesh = result.mesh;
    auto                      keep = [&](std::uint32_t v) {
      if (new_index[v] < 0)
        {
          new_index[v] = static_cast<std::int64_t>(mesh.vertices.size());
          mesh.vertices.push_back(all.vertices[v]);
        }
      return static_cast<std::uint32_t>(new_index[v]);
    };
    for (std::size_t c = 0; c < all.cells.size(); ++c)
      if (is_fluid(all.region[c]))
        {
          const auto &v = all.cells[c];
          mesh.cells.push_back({keep(v[0]), keep(v[1]), keep(v[2]), keep(v[3])});
          mesh.region.push_back(all.region[c]);
        }
    for (const auto &f : boundary)
      mesh.boundary.push_back({{keep(f.vertices[0]), keep(f.vertices[1]), keep(f.vertices[2])}, f.id});

    // 7. Checks and numbers.
    info.opening_m            = opening;
    info.n_vertices           = mesh.vertices.size();
    info.shape                = parameters.settings.shape;
    info.gap_layers           = lay.Ng;
    info.port_segments        = poly.size();
    info.n_stations           = lay.shape.stations().size();
    info.closed_to_m          = lay.x_closed;
    info.cutoff_thickness_m   = lay.h_cut;
    info.min_open_gap_m       = lay.h_cut;
    info.shape_sampling_error = lay.shape.max_sampling_error();
    info.quality              = measure_quality(mesh);
    info.quality.min_floor_angle_deg = min_angle_deg(floor);
    info.fluid_volume_m3      = info.quality.all.volume_m3;
    info.gap_volume_m3        = info.quality.region[gap].volume_m3;
    const double closed_integral = lay.shape.integral_to_station(lay.j_closed);
    const double reed_integral   = lay.shape.integral_to_station(lay.shape.stations().size() - 1);
    info.exact_fluid_volume_m3 = lay.Lp * lay.Wp * lay.Hp + M_PI * lay.r * lay.r * lay.ell -
                                 lay.W * lay.L * lay.t - lay.W * opening * closed_integral;
    info.exact_gap_volume_m3   = lay.W * opening * (reed_integral - closed_integral);
    for (const auto &f : mesh.boundary)
      {
        ++info.boundary_faces[f.id];
        info.boundary_area_m2[f.id] += triangle_area(mesh.vertices[f.vertices[0]],
                                                     mesh.vertices[f.vertices[1]],
                                                     mesh.vertices[f.vertices[2]]);
      }
    info.exact_inlet_area_m2  = M_PI * lay.r * lay.r;
    info.exact_outlet_area_m2 = g.outlet_area_m2();
    info.surface              = check_surface(mesh);
    lap("checks (CGAL surface, quality)");
    info.wall_time_s = std::chrono::duration<double>(Clock::now() - start).count();

    if (!info.surface.closed || info.surface.self_intersecting || !info.surface.outward)
      throw MeshError(std::string("the fluid's boundary is ") +
                      (!info.surface.closed ? "not a closed manifold surface"
                       : info.surface.self_intersecting ? "self-intersecting"
                                                        : "not oriented outwards"));
    for (int id = inlet; id <= reed; ++id)
      if (info.boundary_faces[id] == 0)
        throw MeshError("no boundary face carries id " + std::to_string(id) + " (" +
                        boundary_name(static_cast<std::uint8_t>(id)) + ")");
    return result;
  }

  nlohmann::json to_json(const MeshInfo &i)
  {
    using nlohmann::json;
    const auto &q = i.quality;
    json regions  = json::object();
    for (int r = 0; r < n_regions; ++r)
      regions[region_name(static_cast<std::uint8_t>(r))] = {
        {"n_cells", q.region[r].n_cells},
        {"volume_m3", q.region[r].volume_m3},
        {"min_dihedral_deg", q.region[r].n_cells ? q.region[r].min_dihedral_deg : 0.0},
        {"max_aspect_ratio", q.region[r].max_aspect_ratio}};
    json boundary = json::object();
    for (int id = inlet; id <= reed; ++id)
      {
        json b = {{"id", id},
                  {"n_faces", i.boundary_faces[id]},
                  {"area_m2", i.boundary_area_m2[id]}};
        if (id == inlet)
          b["exact_area_m2"] = i.exact_inlet_area_m2;
        if (id == outlet)
          b["exact_area_m2"] = i.exact_outlet_area_m2;
        boundary[boundary_name(static_cast<std::uint8_t>(id))] = b;
      }
    json timings = json::object();
    for (const auto &[name, t] : i.timings_s)
      timings[name] = t;
    return {
      {"opening_m", i.opening_m},
      {"n_cells", q.all.n_cells},
      {"n_vertices", i.n_vertices},
      {"min_dihedral_deg", q.all.min_dihedral_deg},
      {"max_aspect_ratio", q.all.max_aspect_ratio},
      {"fluid_volume_m3", i.fluid_volume_m3},
      {"exact_fluid_volume_m3", i.exact_fluid_volume_m3},
      {"volume_rel_error", (i.fluid_volume_m3 - i.exact_fluid_volume_m3) / i.exact_fluid_volume_m3},
      {"gap_layers", i.gap_layers},
      {"gap", {{"volume_m3", i.gap_volume_m3},
               {"exact_volume_m3", i.exact_gap_volume_m3},
               {"thinnest_open_gap_m", i.min_open_gap_m},
               {"thinnest_layer_m", i.min_open_gap_m / static_cast<double>(i.gap_layers)}}},
      {"closed_gap", {{"from_clamp_to_m", i.closed_to_m},
                      {"cutoff_thickness_m", i.cutoff_thickness_m},
                      {"note", "the gap under the reed is treated as closed (a wall) from the clamp"
                               " line to from_clamp_to_m, where it is thinner than cutoff_thickness_m"}}},
      {"shape", {{"name", i.shape},
                 {"stations", i.n_stations},
                 {"max_sampling_error_phi", i.shape_sampling_error}}},
      {"port_segments", i.port_segments},
      {"floor_triangles", i.n_floor_triangles},
      {"min_floor_angle_deg", q.min_floor_angle_deg},
      {"regions", regions},
      {"boundary", boundary},
      {"surface_check", {{"closed", i.surface.closed},
                         {"self_intersecting", i.surface.self_intersecting},
                         {"outward", i.surface.outward},
                         {"volume_m3", i.surface.volume_m3},
                         {"n_faces", i.surface.n_faces}}},
      {"tetgen", {{"switches", i.tetgen_switches}, {"n_cells", i.n_bulk_cells}}},
      {"timings_s", timings},
      {"wall_time_s", i.wall_time_s}};
  }
} // namespace rectify::mesher
