#include "common/polygon.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rectify::geometry
{
  namespace
  {
    using K        = CGAL::Exact_predicates_inexact_constructions_kernel;
    using Point    = K::Point_2;
    using Segment  = K::Segment_2;
    using Polygon2 = CGAL::Polygon_2<K>;

    Point    cgal(const XY &p) { return {p[0], p[1]}; }
    Polygon2 cgal(const Polygon &polygon)
    {
      Polygon2 out;
      for (const auto &p : polygon)
        out.push_back(cgal(p));
      return out;
    }
    Segment edge(const Polygon &polygon, std::size_t i)
    {
      return {cgal(polygon[i]), cgal(polygon[(i + 1) % polygon.size()])};
    }
  } // namespace

  double signed_area(const Polygon &polygon)
  {
    double a = 0;
    for (std::size_t i = 0; i < polygon.size(); ++i)
      {
        const auto &p = polygon[i], &q = polygon[(i + 1) % polygon.size()];
        a += p[0] * q[1] - q[0] * p[1];
      }
    return 0.5 * a;
  }

  double perimeter(const Polygon &polygon)
  {
    double l = 0;
    for (std::size_t i = 0; i < polygon.size(); ++i)
      {
        const auto &p = polygon[i], &q = polygon[(i + 1) % polygon.size()];
        l += std::hypot(q[0] - p[0], q[1] - p[1]);
      }
    return l;
  }

  XY centroid(const Polygon &polygon)
  {
    double cx = 0, cy = 0;
    for (std::size_t i = 0; i < polygon.size(); ++i)
      {
        const auto  &p = polygon[i], &q = polygon[(i + 1) % polygon.size()];
        const double c = p[0] * q[1] - q[0] * p[1];
        cx += (p[0] + q[0]) * c;
        cy += (p[1] + q[1]) * c;
      }
    const double a = signed_area(polygon);
    return {cx / (6 * a), cy / (6 * a)};
  }

  std::optional<std::array<std::size_t, 2>> first_self_intersection(const Polygon &polygon)
  {
    const std::size_t n = polygon.size();
    if (n < 3)
      return std::array<std::size_t, 2>{0, 0};
    for (std::size_t i = 0; i < n; ++i)
      if (polygon[i] == polygon[(i + 1) % n])
        return std::array<std::size_t, 2>{i, i};
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j)
        {
          const Segment a = edge(polygon, i), b = edge(polygon, j);
          const bool    next = j == i + 1, wrap = i == 0 && j == n - 1;
          if (next || wrap)
            {
              // Neighbours share one corner; they must not fold back onto each other.
              const Point shared = next ? b.source() : a.source();
              const Point pa = next ? a.source() : a.target(), pb = next ? b.target() : b.source();
              if (CGAL::collinear(pa, shared, pb) && !CGAL::collinear_are_ordered_along_line(pa, shared, pb))
                return std::array<std::size_t, 2>{i, j};
              continue;
            }
          if (CGAL::do_intersect(a, b))
            return std::array<std::size_t, 2>{i, j};
        }
    return std::nullopt;
  }

  Side side_of(const Polygon &polygon, const XY &p)
  {
    const Polygon2 cp = cgal(polygon);
    switch (CGAL::bounded_side_2(cp.vertices_begin(), cp.vertices_end(), cgal(p), K()))
      {
        case CGAL::ON_BOUNDED_SIDE:
          return Side::inside;
        case CGAL::ON_BOUNDARY:
          return Side::on_boundary;
        default:
          return Side::outside;
      }
  }

  double distance_to_segment(const XY &p, const XY &a, const XY &b)
  {
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double l2 = dx * dx + dy * dy;
    double       t  = l2 > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2 : 0.0;
    t               = std::clamp(t, 0.0, 1.0);
    return std::hypot(p[0] - (a[0] + t * dx), p[1] - (a[1] + t * dy));
  }

  double distance_to_boundary(const Polygon &polygon, const XY &p)
  {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < polygon.size(); ++i)
      d = std::min(d, distance_to_segment(p, polygon[i], polygon[(i + 1) % polygon.size()]));
    return d;
  }

  double boundary_distance(const Polygon &a, const Polygon &b)
  {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < a.size(); ++i)
      for (std::size_t j = 0; j < b.size(); ++j)
        {
          const Segment sa = edge(a, i), sb = edge(b, j);
          if (CGAL::do_intersect(sa, sb))
            return 0.0;
          const XY &a0 = a[i], &a1 = a[(i + 1) % a.size()], &b0 = b[j], &b1 = b[(j + 1) % b.size()];
          d = std::min({d, distance_to_segment(a0, b0, b1), distance_to_segment(a1, b0, b1),
                        distance_to_segment(b0, a0, a1), distance_to_segment(b1, a0, a1)});
        }
    return d;
  }

  double narrowest_width(const Polygon &polygon)
  {
    const std::size_t   n = polygon.size();
    std::vector<double> along(n + 1, 0.0); // boundary length from corner 0 to corner i
    for (std::size_t i = 0; i < n; ++i)
      {
        const XY &a = polygon[i], &b = polygon[(i + 1) % n];
        along[i + 1] = along[i] + std::hypot(b[0] - a[0], b[1] - a[1]);
      }
    const double total = along[n];
    const auto   apart = [&](double s, double t) {
      const double d = std::abs(s - t);
      return std::min(d, total - d);
    };
    // Sample points along every edge (corners included), at most total / 400 apart.
    struct Sample
    {
      XY          p;
      double      s;
      std::size_t edge;
    };
    std::vector<Sample> samples;
    for (std::size_t i = 0; i < n; ++i)
      {
        const XY   &a = polygon[i], &b = polygon[(i + 1) % n];
        const double length = along[i + 1] - along[i];
        const auto   k = static_cast<std::size_t>(std::max(1.0, std::ceil(length / (total / 400))));
        for (std::size_t m = 0; m < k; ++m)
          {
            const double t = static_cast<double>(m) / static_cast<double>(k);
            samples.push_back({{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])}, along[i] + t * length, i});
          }
      }
    double width = std::numeric_limits<double>::infinity();
    for (const auto &q : samples)
      for (std::size_t j = 0; j < n; ++j)
        {
          if (j == q.edge || (j + 1) % n == q.edge)
            continue;
          const XY    &a = polygon[j], &b = polygon[(j + 1) % n];
          const double dx = b[0] - a[0], dy = b[1] - a[1], l2 = dx * dx + dy * dy;
          const double t  = std::clamp(((q.p[0] - a[0]) * dx + (q.p[1] - a[1]) * dy) / l2, 0.0, 1.0);
          const double d  = std::hypot(q.p[0] - (a[0] + t * dx), q.p[1] - (a[1] + t * dy));
          if (apart(q.s, along[j] + t * (along[j + 1] - along[j])) > 1.5 * d)
            width = std::min(width, d);
        }
    return width;
  }

  std::vector<std::array<double, 2>> chord_intervals(const Polygon &polygon, double x)
  {
    std::vector<double> ys;
    const std::size_t   n = polygon.size();
    for (std::size_t i = 0; i < n; ++i)
      {
        const XY &a = polygon[i], &b = polygon[(i + 1) % n];
        // Half-open in x, so that a corner on the line counts once (and an
        // edge along the line not at all).
        if ((a[0] <= x && x < b[0]) || (b[0] <= x && x < a[0]))
          ys.push_back(a[1] + (x - a[0]) / (b[0] - a[0]) * (b[1] - a[1]));
      }
    std::sort(ys.begin(), ys.end());
    std::vector<std::array<double, 2>> out;
    for (std::size_t k = 0; k + 1 < ys.size(); k += 2)
      out.push_back({ys[k], ys[k + 1]});
    return out;
  }

  double chord_width(const Polygon &polygon, double x)
  {
    double w = 0;
    for (const auto &[y0, y1] : chord_intervals(polygon, x))
      w += y1 - y0;
    return w;
  }

  std::vector<double> fillet_tangent_lengths(const Polygon &polygon, const std::vector<double> &radii)
  {
    const auto          angles = interior_angles(polygon);
    std::vector<double> tangent(polygon.size(), 0.0);
    for (std::size_t i = 0; i < polygon.size(); ++i)
      if (radii[i] > 0)
        {
          if (std::abs(angles[i] - M_PI) < 1e-9)
            throw std::invalid_argument("corner " + std::to_string(i + 1) + " is straight (180 degrees): nothing to round");
          tangent[i] = radii[i] / std::abs(std::tan(0.5 * angles[i]));
        }
    return tangent;
  }

  std::vector<double> interior_angles(const Polygon &polygon)
  {
    const std::size_t   n = polygon.size();
    std::vector<double> angles(n);
    for (std::size_t i = 0; i < n; ++i)
      {
        const XY    &prev = polygon[(i + n - 1) % n], &p = polygon[i], &next = polygon[(i + 1) % n];
        const double in   = std::atan2(p[1] - prev[1], p[0] - prev[0]);
        const double out  = std::atan2(next[1] - p[1], next[0] - p[0]);
        double       turn = out - in; // left turn positive
        while (turn > M_PI)
          turn -= 2 * M_PI;
        while (turn <= -M_PI)
          turn += 2 * M_PI;
        angles[i] = M_PI - turn;
      }
    return angles;
  }

  Polygon rounded(const Polygon &polygon, const std::vector<double> &radii, double max_step_rad)
  {
    const std::size_t n = polygon.size();
    if (radii.size() != n)
      throw std::invalid_argument("rounded: one radius per corner");
    const auto tangent = fillet_tangent_lengths(polygon, radii);
    const auto length = [&](std::size_t i) {
      const XY &a = polygon[i], &b = polygon[(i + 1) % n];
      return std::hypot(b[0] - a[0], b[1] - a[1]);
    };
    for (std::size_t i = 0; i < n; ++i)
      {
        const std::size_t next = (i + 1) % n;
        if (tangent[i] + tangent[next] > length(i) * (1 + 1e-12))
          throw std::invalid_argument("the fillets of corners " + std::to_string(i + 1) + " and " +
                                      std::to_string(next + 1) + " need " + std::to_string((tangent[i] + tangent[next]) * 1e3) +
                                      " mm of their edge, which is " + std::to_string(length(i) * 1e3) + " mm long");
      }
    Polygon out;
    for (std::size_t i = 0; i < n; ++i)
      {
        const XY &prev = polygon[(i + n - 1) % n], &p = polygon[i], &next = polygon[(i + 1) % n];
        if (!(radii[i] > 0))
          {
            out.push_back(p);
            continue;
          }
        const double lin = std::hypot(p[0] - prev[0], p[1] - prev[1]), lout = std::hypot(next[0] - p[0], next[1] - p[1]);
        const XY     din{(p[0] - prev[0]) / lin, (p[1] - prev[1]) / lin};
        const XY     dout{(next[0] - p[0]) / lout, (next[1] - p[1]) / lout};
        const XY     t0{p[0] - tangent[i] * din[0], p[1] - tangent[i] * din[1]};
        const XY     t1{p[0] + tangent[i] * dout[0], p[1] + tangent[i] * dout[1]};
        // The centre lies on the inner side of the incoming edge: to its
        // left for a convex corner of a counter-clockwise polygon.
        const double cross = din[0] * dout[1] - din[1] * dout[0];
        const double sign  = cross > 0 ? 1.0 : -1.0;
        const XY     c{t0[0] - sign * radii[i] * din[1], t0[1] + sign * radii[i] * din[0]};
        const double a0 = std::atan2(t0[1] - c[1], t0[0] - c[0]);
        double       a1 = std::atan2(t1[1] - c[1], t1[0] - c[0]);
        double       sweep = a1 - a0;
        while (sign * sweep < 0)
          sweep += sign * 2 * M_PI;
        const auto steps = static_cast<std::size_t>(std::max(1.0, std::ceil(std::abs(sweep) / max_step_rad - 1e-9)));
        // The arc's ends are the tangent points themselves (exactly on the
        // edges: a fillet's end on an axis-parallel edge keeps its coordinate).
        out.push_back(t0);
        for (std::size_t k = 1; k < steps; ++k)
          {
            const double a = a0 + sweep * static_cast<double>(k) / static_cast<double>(steps);
            out.push_back({c[0] + radii[i] * std::cos(a), c[1] + radii[i] * std::sin(a)});
          }
        out.push_back(t1);
      }
    // A fillet that uses its whole edge leaves its tangent point twice.
    Polygon dedup;
    for (const auto &p : out)
      if (dedup.empty() || std::hypot(p[0] - dedup.back()[0], p[1] - dedup.back()[1]) > 1e-12)
        dedup.push_back(p);
    while (dedup.size() > 1 && std::hypot(dedup.front()[0] - dedup.back()[0], dedup.front()[1] - dedup.back()[1]) <= 1e-12)
      dedup.pop_back();
    return dedup;
  }

  Polygon circle_polygon(const XY &center, double radius, std::size_t n)
  {
    // Equal area: n/2 R^2 sin(2 pi / n) = pi r^2.
    const double R = radius * std::sqrt(2 * M_PI / (static_cast<double>(n) * std::sin(2 * M_PI / static_cast<double>(n))));
    Polygon      out;
    for (std::size_t k = 0; k < n; ++k)
      {
        const double a = 2 * M_PI * static_cast<double>(k) / static_cast<double>(n);
        out.push_back({center[0] + R * std::cos(a), center[1] + R * std::sin(a)});
      }
    return out;
  }
} // namespace rectify::geometry
