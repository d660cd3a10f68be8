#include "common/valve_geometry.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "common/io.h"

namespace rectify
{
  using geometry::Polygon;
  using geometry::XY;

  namespace
  {
    /// Fillet arcs are drawn in steps of at most this angle.
    constexpr double fillet_step_rad = M_PI / 36;

    /// Metres as millimetres to the nanometre, for messages.
    std::string in_mm(double metres) { return format_number(std::round(metres * 1e9) / 1e6); }
    std::string mm(double metres) { return in_mm(metres) + " mm"; }
    std::string point_mm(const XY &p) { return "(" + in_mm(p[0]) + ", " + in_mm(p[1]) + ") mm"; }

    /// Locations in messages: "case file 'x' [geometry] key" or, for a
    /// geometry built in code, "geometry key".
    using Where = std::function<std::string(const std::string &table, const std::string &key)>;

    std::string port_table(std::size_t i) { return "port#" + std::to_string(i + 1); }

    /// How close to x = 0 a corner must be to lie on the pocket's wall: 1e-9
    /// of the outline's extent.
    double wall_tolerance(const Polygon &outline)
    {
      double extent = 0;
      for (const XY &p : outline)
        extent = std::max({extent, std::abs(p[0]), std::abs(p[1])});
      return 1e-9 * extent;
    }

    /// The seat between two ports: the shortest distance between their
    /// edges, exact for circles; 0 or less if they overlap.
    double gap_between(const Port &a, const Port &b)
    {
      if (a.circular && b.circular)
        return std::hypot(a.center_m[0] - b.center_m[0], a.center_m[1] - b.center_m[1]) - 0.5 * a.diameter_m -
               0.5 * b.diameter_m;
      if (a.circular != b.circular)
        {
          const Port &c = a.circular ? a : b, &p = a.circular ? b : a;
          if (geometry::side_of(p.outline_m, c.center_m) != geometry::Side::outside)
            return 0.0;
          return geometry::distance_to_boundary(p.outline_m, c.center_m) - 0.5 * c.diameter_m;
        }
      if (geometry::side_of(a.outline_m, b.outline_m[0]) != geometry::Side::outside ||
          geometry::side_of(b.outline_m, a.outline_m[0]) != geometry::Side::outside)
        return 0.0;
      return geometry::boundary_distance(a.outline_m, b.outline_m);
    }

    Polygon counter_clockwise(Polygon p)
    {
      if (geometry::signed_area(p) < 0)
        std::reverse(p.begin(), p.end());
      return p;
    }

    /// An outline from a CSV file with columns x_m and y_m.
    Polygon read_outline_csv(const std::filesystem::path &path)
    {
      const CsvData     csv = read_csv(path);
      const std::size_t ix = csv.column_index("x_m", path.string()), iy = csv.column_index("y_m", path.string());
      Polygon           out;
      for (const auto &row : csv.rows)
        out.push_back({row[ix], row[iy]});
      return out;
    }

    /// The outline a case gives under `table`: `prefix`_m (points) or
    /// `prefix`_csv (a file); empty if neither. As written (either way round).
    Polygon read_outline(const CaseFile &f, const std::string &table, const std::string &prefix)
    {
      const bool as_points = f.has(table, prefix + "_m"), as_csv = f.has(table, prefix + "_csv");
      if (as_points && as_csv)
        throw InputError(f.where(table, prefix + "_csv") + ": give the outline either as " + prefix + "_m or as " +
                         prefix + "_csv, not both");
      f.declare(table, prefix + "_csv");
      const Bounds finite;
      if (as_points)
        return f.points(table, prefix + "_m", finite);
      f.points(table, prefix + "_m", finite); // declares and records it
      if (!as_csv)
        return {};
      const std::string file = f.text(table, prefix + "_csv", "");
      try
        {
          return read_outline_csv(f.resolve(file));
        }
      catch (const InputError &e)
        {
          throw InputError(f.where(table, prefix + "_csv") + " = '" + file + "': " + e.what());
        }
    }
  } // namespace

  // ------------------------------------------------------------------ Port

  double Port::land_under(const Polygon &reed) const
  {
    return circular ? geometry::distance_to_boundary(reed, center_m) - 0.5 * diameter_m
                    : geometry::boundary_distance(reed, outline_m);
  }

  double Port::hydraulic_diameter_m() const { return 4 * area_m2() / perimeter_m(); }

  double Port::area_m2() const
  {
    return circular ? 0.25 * M_PI * diameter_m * diameter_m : std::abs(geometry::signed_area(outline_m));
  }

  double Port::perimeter_m() const { return circular ? M_PI * diameter_m : geometry::perimeter(outline_m); }

  Polygon Port::polygon(std::size_t circle_sides) const
  {
    return circular ? geometry::circle_polygon(center_m, 0.5 * diameter_m, circle_sides) : outline_m;
  }

  XY Port::centroid_m() const { return circular ? center_m : geometry::centroid(outline_m); }

  bool Port::contains(const XY &p) const
  {
    if (circular)
      return std::hypot(p[0] - center_m[0], p[1] - center_m[1]) < 0.5 * diameter_m;
    return geometry::side_of(outline_m, p) == geometry::Side::inside;
  }

  double Port::distance_to_edge(const XY &p) const
  {
    if (circular)
      return std::abs(std::hypot(p[0] - center_m[0], p[1] - center_m[1]) - 0.5 * diameter_m);
    return geometry::distance_to_boundary(outline_m, p);
  }

  nlohmann::json Port::to_json() const
  {
    nlohmann::json j = {{"length_m", length_m},
                        {"area_m2", area_m2()},
                        {"perimeter_m", perimeter_m()},
                        {"centroid_m", {centroid_m()[0], centroid_m()[1]}},
                        {"hydraulic_diameter_m", hydraulic_diameter_m()}};
    if (circular)
      {
        j["center_m"]   = {center_m[0], center_m[1]};
        j["diameter_m"] = diameter_m;
      }
    else
      {
        j["outline_m"] = nlohmann::json::array();
        for (const auto &p : outline_m)
          j["outline_m"].push_back({p[0], p[1]});
      }
    return j;
  }

  // --------------------------------------------------------- ValveGeometry

  Polygon ValveGeometry::reed_corners() const
  {
    if (!reed_outline_m.empty())
      return reed_outline_m;
    const double h = 0.5 * reed_width_m;
    return {{0.0, -h}, {reed_length_m, -h}, {reed_length_m, h}, {0.0, h}};
  }

  std::vector<double> ValveGeometry::fillet_radii() const
  {
    if (!reed_outline_m.empty() && reed_fillet_radii_m.size() == reed_outline_m.size())
      return reed_fillet_radii_m;
    return std::vector<double>(reed_corners().size(), 0.0);
  }

  Polygon ValveGeometry::reed_boundary() const
  {
    return geometry::rounded(reed_corners(), fillet_radii(), fillet_step_rad);
  }

  std::array<double, 2> ValveGeometry::clamp_line_y() const
  {
    if (!reed_outline_m.empty())
      return clamp_y_m;
    return {-0.5 * reed_width_m, 0.5 * reed_width_m};
  }

  std::vector<Port> ValveGeometry::ports() const
  {
    if (!port_list.empty())
      return port_list;
    Port p;
    p.circular   = true;
    p.center_m   = {port_center_x_m, 0.0};
    p.diameter_m = port_diameter_m;
    p.length_m   = port_length_m;
    return {p};
  }

  double ValveGeometry::reed_area_m2() const { return std::abs(geometry::signed_area(reed_boundary())); }

  double ValveGeometry::ports_area_m2() const
  {
    double a = 0;
    for (const auto &p : ports())
      a += p.area_m2();
    return a;
  }

  double ValveGeometry::seat_land_m() const
  {
    const Polygon boundary = reed_boundary();
    double        land     = std::numeric_limits<double>::infinity();
    for (const auto &p : ports())
      land = std::min(land, p.land_under(boundary));
    return land;
  }

  std::vector<GeometryFeature> ValveGeometry::features() const
  {
    std::vector<GeometryFeature> out;
    const Polygon c      = reed_corners();
    const auto    radii  = fillet_radii();
    const auto    n      = c.size();
    const auto    tangent = geometry::fillet_tangent_lengths(c, radii);
    for (std::size_t i = 0; i < n; ++i)
      if (radii[i] > 0)
        out.push_back({radii[i], "the fillet radius at corner " + std::to_string(i + 1) + " of the reed"});
    for (std::size_t i = 0; i < n; ++i)
      {
        const XY    &a = c[i], &b = c[(i + 1) % n];
        const double straight = std::hypot(b[0] - a[0], b[1] - a[1]) - tangent[i] - tangent[(i + 1) % n];
        if (straight > 1e-12)
          out.push_back({straight, "the straight part of the reed's edge from corner " + std::to_string(i + 1) + " to " +
                                     std::to_string((i + 1) % n + 1)});
      }
    const Polygon boundary = reed_boundary();
    out.push_back({geometry::narrowest_width(boundary), "the reed's narrowest width"});
    const auto ps = ports();
    for (std::size_t k = 0; k < ps.size(); ++k)
      {
        const std::string name = "port " + std::to_string(k + 1);
        if (ps[k].circular)
          out.push_back({ps[k].diameter_m, name + "'s diameter"});
        else
          out.push_back({geometry::narrowest_width(ps[k].outline_m), name + "'s narrowest width"});
        out.push_back({ps[k].land_under(boundary), "the seat land around " + name});
        for (std::size_t j = k + 1; j < ps.size(); ++j)
          out.push_back({gap_between(ps[k], ps[j]),
                         "the seat between ports " + std::to_string(k + 1) + " and " + std::to_string(j + 1)});
      }
    std::stable_sort(out.begin(), out.end(),
                     [](const GeometryFeature &a, const GeometryFeature &b) { return a.size_m < b.size_m; });
    return out;
  }

  double ValveGeometry::outlet_area_m2() const
  {
    if (outlet_face == "ceiling")
      return pocket_length_m * pocket_width_m;
    if (outlet_face == "x-max")
      return pocket_width_m * pocket_height_m;
    return pocket_length_m * pocket_height_m;
  }

  namespace
  {
    /// The shorthand's port (one circle on y = 0), with the messages it always had.
    void check_shorthand_port(const ValveGeometry &g, const Where &where)
    {
      const std::string t = "geometry";
      const double      r = 0.5 * g.port_diameter_m;
      if (g.port_center_x_m - r <= 0.0 || g.port_center_x_m + r >= g.pocket_length_m || r >= 0.5 * g.pocket_width_m)
        throw InputError(where(t, "port_center_x_m") + " = " + format_number(g.port_center_x_m) +
                         " with port_diameter_m = " + format_number(g.port_diameter_m) +
                         ": the port lies outside the seat (the pocket floor [0, " + format_number(g.pocket_length_m) +
                         "] x [-" + format_number(0.5 * g.pocket_width_m) + ", " +
                         format_number(0.5 * g.pocket_width_m) + "] m)");
    }

    /// The shorthand's rectangle inside the pocket.
    void check_rectangle(const ValveGeometry &g, const Where &where)
    {
      const std::string t = "geometry";
      if (g.reed_length_m >= g.pocket_length_m)
        throw InputError(where(t, "reed_length_m") + " = " + format_number(g.reed_length_m) +
                         ": the reed must end inside the pocket (pocket_length_m = " + format_number(g.pocket_length_m) +
                         ")");
      if (g.reed_width_m >= g.pocket_width_m)
        throw InputError(where(t, "reed_width_m") + " = " + format_number(g.reed_width_m) +
                         ": the reed must fit inside the pocket (pocket_width_m = " + format_number(g.pocket_width_m) +
                         ")");
    }

    /// The shorthand's port under the shorthand's rectangle.
    void check_shorthand_cover(const ValveGeometry &g, const Where &where)
    {
      const std::string t = "geometry";
      const double      r = 0.5 * g.port_diameter_m;
      if (g.port_center_x_m - r <= 0.0 || g.port_center_x_m + r >= g.reed_length_m || r >= 0.5 * g.reed_width_m)
        throw InputError(where(t, "port_diameter_m") + " = " + format_number(g.port_diameter_m) +
                         " with port_center_x_m = " + format_number(g.port_center_x_m) + ": the reed (" +
                         format_number(g.reed_length_m) + " x " + format_number(g.reed_width_m) +
                         " m from the clamp line) does not cover its port");
    }

    /// The outline's checks: simple, its clamp line the edge on x = 0, no
    /// fillet at the clamp, inside the pocket.
    void check_outline(const ValveGeometry &g, const Where &where)
    {
      const std::string t = "geometry", key = "reed_outline_m";
      const Polygon    &c = g.reed_outline_m;
      if (c.size() < 3)
        throw InputError(where(t, key) + ": an outline needs at least 3 corners, got " + std::to_string(c.size()));
      if (const auto cross = geometry::first_self_intersection(c))
        {
          const auto [i, j] = *cross;
          if (i == j)
            throw InputError(where(t, key) + ": corners " + std::to_string(i + 1) + " and " +
                             std::to_string((i + 1) % c.size() + 1) + " are the same point " + point_mm(c[i]));
          throw InputError(where(t, key) + ": the outline is not simple: its edge from corner " + std::to_string(i + 1) +
                           " " + point_mm(c[i]) + " crosses or touches its edge from corner " + std::to_string(j + 1) +
                           " " + point_mm(c[j]));
        }
      if (g.reed_fillet_radii_m.size() != c.size())
        throw InputError(where(t, "reed_fillet_radii_m") + ": " + std::to_string(g.reed_fillet_radii_m.size()) +
                         " radii for an outline of " + std::to_string(c.size()) + " corners");
      const double tol = wall_tolerance(c);
      std::vector<std::size_t> on_wall;
      for (std::size_t i = 0; i < c.size(); ++i)
        {
          if (c[i][0] < -tol)
            throw InputError(where(t, key) + ", corner " + std::to_string(i + 1) + " " + point_mm(c[i]) +
                             ": the reed lies in x >= 0, from its clamp line on the pocket's wall x = 0");
          if (std::abs(c[i][0]) <= tol)
            on_wall.push_back(i);
        }
      const auto n = c.size();
      if (on_wall.size() != 2 || !((on_wall[1] == on_wall[0] + 1) || (on_wall[0] == 0 && on_wall[1] == n - 1)))
        throw InputError(where(t, key) + ": the clamp line must be one edge of the outline on x = 0 (the pocket's "
                                         "wall); the outline has " + std::to_string(on_wall.size()) +
                         " corner(s) on x = 0");
      const double y0 = std::min(c[on_wall[0]][1], c[on_wall[1]][1]), y1 = std::max(c[on_wall[0]][1], c[on_wall[1]][1]);
      if (std::abs(g.clamp_y_m[0] - y0) > tol || std::abs(g.clamp_y_m[1] - y1) > tol)
        throw InputError(where(t, "clamp_line_m") + " = [[0, " + format_number(g.clamp_y_m[0]) + "], [0, " +
                         format_number(g.clamp_y_m[1]) + "]]: not on the outline, whose edge on x = 0 runs from y = " +
                         format_number(y0) + " to " + format_number(y1) + " m");
      for (const std::size_t i : on_wall)
        if (g.reed_fillet_radii_m[i] > 0)
          throw InputError(where(t, "reed_fillet_radii_m") + ", corner " + std::to_string(i + 1) + " " +
                           point_mm(c[i]) + " = " + format_number(g.reed_fillet_radii_m[i]) +
                           ": a corner of the clamp line must be sharp (the reed meets the wall there)");
      Polygon boundary;
      try
        {
          boundary = g.reed_boundary();
        }
      catch (const std::invalid_argument &e)
        {
          throw InputError(where(t, "reed_fillet_radii_m") + ": " + e.what());
        }
      if (const auto cross = geometry::first_self_intersection(boundary))
        throw InputError(where(t, "reed_fillet_radii_m") + ": the outline with its fillets is not simple (near " +
                         point_mm(boundary[(*cross)[0]]) + ")");
      for (const XY &p : boundary)
        if (p[0] >= g.pocket_length_m || std::abs(p[1]) >= 0.5 * g.pocket_width_m)
          throw InputError(where(t, key) + ": the reed reaches " + point_mm(p) +
                           ", outside the pocket's floor [0, " + mm(g.pocket_length_m) + "] x [-" +
                           mm(0.5 * g.pocket_width_m) + ", " + mm(0.5 * g.pocket_width_m) + "]");
    }

    /// Each port's own shape, its cover by the reed, and the ports apart.
    void check_ports(const ValveGeometry &g, const Where &where)
    {
      const Polygon boundary = g.reed_boundary();
      const auto    ports    = g.ports();
      const bool    listed   = !g.port_list.empty();
      const auto    name     = [&](std::size_t k) { return listed ? "port " + std::to_string(k + 1) : std::string("the port"); };
      const auto    at       = [&](std::size_t k, const std::string &key) {
        if (listed)
          return where(port_table(k), key);
        return where("geometry", key == "center_m" ? "port_center_x_m" : "port_" + key);
      };
      for (std::size_t k = 0; k < ports.size(); ++k)
        {
          const Port &p = ports[k];
          if (!(p.length_m > 0) || !std::isfinite(p.length_m))
            throw InputError(at(k, "length_m") + " = " + format_number(p.length_m) + ": must be > 0");
          if (!p.circular)
            {
              if (p.outline_m.size() < 3)
                throw InputError(at(k, "outline_m") + ": a port's outline needs at least 3 corners, got " +
                                 std::to_string(p.outline_m.size()));
              if (const auto cross = geometry::first_self_intersection(p.outline_m))
                throw InputError(at(k, "outline_m") + ": the outline is not simple (its edge from corner " +
                                 std::to_string((*cross)[0] + 1) + " meets its edge from corner " +
                                 std::to_string((*cross)[1] + 1) + ")");
            }
          const bool   inside = geometry::side_of(boundary, p.centroid_m()) == geometry::Side::inside;
          const double land   = p.land_under(boundary);
          bool covered = inside && land > 0;
          if (covered && !p.circular)
            for (const XY &q : p.outline_m)
              covered = covered && geometry::side_of(boundary, q) == geometry::Side::inside;
          const std::string key = p.circular ? "diameter_m" : "outline_m";
          if (!covered)
            throw InputError(at(k, p.circular ? "center_m" : key) + ": the reed does not cover " + name(k) +
                             " (" + (p.circular ? "centre " + point_mm(p.center_m) + ", diameter " + mm(p.diameter_m)
                                                : "centroid " + point_mm(p.centroid_m())) + ")");
          if (land < g.seat_land_min_m)
            throw InputError(at(k, p.circular ? "center_m" : key) + ": the reed covers " + name(k) +
                             " with a seat land of " + mm(land) + ", less than seat_land_min_m = " +
                             mm(g.seat_land_min_m) + " ([geometry])");
        }
      for (std::size_t a = 0; a < ports.size(); ++a)
        for (std::size_t b = a + 1; b < ports.size(); ++b)
          {
            const double d = gap_between(ports[a], ports[b]);
            if (d <= 0)
              throw InputError(where(port_table(b), ports[b].circular ? "center_m" : "outline_m") + ": " + name(b) +
                               " overlaps " + name(a));
            if (d < g.seat_land_min_m)
              throw InputError(where(port_table(b), ports[b].circular ? "center_m" : "outline_m") + ": " + name(b) +
                               " is " + mm(d) + " from " + name(a) + ", less than seat_land_min_m = " +
                               mm(g.seat_land_min_m) + " of seat between them");
          }
    }
  } // namespace

  namespace
  {
    void check_geometry(const ValveGeometry &g, const Where &where)
    {
      const std::string t = "geometry";
      if (g.port_list.empty())
        check_shorthand_port(g, where);
      if (g.reed_outline_m.empty())
        check_rectangle(g, where);
      else
        check_outline(g, where);
      if (g.is_shorthand())
        check_shorthand_cover(g, where);
      if (g.reed_thickness_m >= g.pocket_height_m)
        throw InputError(where(t, "reed_thickness_m") + " = " + format_number(g.reed_thickness_m) +
                         ": the closed reed would not fit under the pocket ceiling (pocket_height_m = " +
                         format_number(g.pocket_height_m) + ")");
      check_ports(g, where);
      if (!std::isnan(g.stop_height_m) &&
          !(g.stop_height_m > g.reed_thickness_m && g.stop_height_m <= g.pocket_height_m))
        throw InputError(where(t, "stop_height_m") + " = " + format_number(g.stop_height_m) +
                         (g.stop_height_m > g.pocket_height_m ?
                            ": the stop would stand above the pocket's ceiling (pocket_height_m = " +
                              format_number(g.pocket_height_m) + ")" :
                            ": the stop must stand above the closed reed (reed_thickness_m = " +
                              format_number(g.reed_thickness_m) + "), in (reed_thickness_m, pocket_height_m]"));
      if (g.reed_thickness_m >= 0.5 * std::min(g.reed_length_m, g.reed_width_m))
        throw InputError(where(t, "reed_thickness_m") + " = " + format_number(g.reed_thickness_m) +
                         ": a reed must be a thin plate (thickness below half its length and width)");
    }
  } // namespace

  void ValveGeometry::check(const std::string &source) const
  {
    check_geometry(*this, [&](const std::string &table, const std::string &key) {
      return source + " [" + table + "] " + key;
    });
  }

  nlohmann::json ValveGeometry::to_json() const
  {
    nlohmann::json j = {{"reed_length_m", reed_length_m},       {"reed_width_m", reed_width_m},
                        {"reed_thickness_m", reed_thickness_m}, {"port_diameter_m", port_diameter_m},
                        {"port_center_x_m", port_center_x_m},   {"port_length_m", port_length_m},
                        {"pocket_length_m", pocket_length_m},   {"pocket_width_m", pocket_width_m},
                        {"pocket_height_m", pocket_height_m},   {"outlet_face", outlet_face}};
    if (is_shorthand())
      return j;
    j.erase("port_diameter_m");
    j.erase("port_center_x_m");
    j.erase("port_length_m");
    j["reed_outline_m"] = nlohmann::json::array();
    for (const auto &p : reed_corners())
      j["reed_outline_m"].push_back({p[0], p[1]});
    j["reed_fillet_radii_m"] = fillet_radii();
    const auto [y0, y1]      = clamp_line_y();
    j["clamp_line_m"]        = {{0.0, y0}, {0.0, y1}};
    j["ports"]               = nlohmann::json::array();
    for (const auto &p : ports())
      j["ports"].push_back(p.to_json());
    j["seat_land_min_m"] = seat_land_min_m;
    return j;
  }

  namespace
  {
    /// The reed as a rectangle or as an outline, the ports as one circle or
    /// as [[port]] tables: never both, nor an outline's keys without one.
    void check_either_or(const CaseFile &f, const std::string &t, bool outline, std::size_t n_ports)
    {
      if (outline)
        for (const std::string key : {"reed_length_m", "reed_width_m"})
          if (f.has(t, key))
            throw InputError(f.where(t, key) + ": give the reed either as reed_length_m and reed_width_m (a "
                                               "rectangle) or as its outline (reed_outline_m or reed_outline_csv), not both");
      if (!outline)
        for (const std::string key : {"reed_fillet_radius_m", "reed_fillet_radii_m", "clamp_line_m"})
          if (f.has(t, key))
            throw InputError(f.where(t, key) + ": applies to a reed given as its outline (reed_outline_m or "
                                               "reed_outline_csv)");
      if (n_ports > 0)
        for (const std::string key : {"port_diameter_m", "port_center_x_m"})
          if (f.has(t, key))
            throw InputError(f.where(t, key) + ": give the ports either as port_diameter_m and port_center_x_m (one "
                                               "circle) or as [[port]] tables, not both");
    }

    /// A reed given as its outline: counter-clockwise, its corners' fillet
    /// radii, its clamp line (as given, else the outline's edge on x = 0).
    void read_reed_outline(const CaseFile &f, const std::string &t, ValveGeometry &g)
    {
      g.reed_outline_m = read_outline(f, t, "reed_outline");
      if (f.has(t, "reed_fillet_radii_m"))
        g.reed_fillet_radii_m = f.reals(t, "reed_fillet_radii_m", {}, Bounds::non_negative());
      // Counter-clockwise from here on (a simple outline only: check_outline
      // names a crossing in the file's order); the radii follow their corners.
      const auto &c = g.reed_outline_m;
      if (c.size() >= 3 && !geometry::first_self_intersection(c) && geometry::signed_area(c) < 0)
        {
          std::reverse(g.reed_outline_m.begin(), g.reed_outline_m.end());
          std::reverse(g.reed_fillet_radii_m.begin(), g.reed_fillet_radii_m.end());
        }
      if (f.has(t, "reed_fillet_radii_m") && f.has(t, "reed_fillet_radius_m"))
        throw InputError(f.where(t, "reed_fillet_radius_m") +
                         ": give one radius for every corner (reed_fillet_radius_m) or one per corner "
                         "(reed_fillet_radii_m), not both");
      f.declare(t, "reed_fillet_radii_m");
      if (!f.has(t, "reed_fillet_radii_m"))
        {
          const double r = f.real(t, "reed_fillet_radius_m", 0.0, Bounds::non_negative());
          g.reed_fillet_radii_m.assign(g.reed_outline_m.size(), r);
          // One radius for all: the clamp line's two corners stay sharp.
          const double tol = wall_tolerance(g.reed_outline_m);
          for (std::size_t i = 0; i < g.reed_outline_m.size(); ++i)
            if (std::abs(g.reed_outline_m[i][0]) <= tol)
              g.reed_fillet_radii_m[i] = 0;
        }
      else
        f.declare(t, "reed_fillet_radius_m");
      // The clamp line: as given, else the outline's edge on x = 0.
      const auto clamp = f.points(t, "clamp_line_m", Bounds());
      if (!clamp.empty())
        {
          if (clamp.size() != 2 || clamp[0][0] != 0.0 || clamp[1][0] != 0.0 || clamp[0][1] == clamp[1][1])
            throw InputError(f.where(t, "clamp_line_m") +
                             ": expected two different points on x = 0, [[0, y0], [0, y1]] (the clamp line lies "
                             "on the pocket's wall)");
          g.clamp_y_m = {std::min(clamp[0][1], clamp[1][1]), std::max(clamp[0][1], clamp[1][1])};
        }
      else
        {
          double       lo = std::numeric_limits<double>::infinity(), hi = -lo;
          const double tol = wall_tolerance(g.reed_outline_m);
          for (const XY &p : g.reed_outline_m)
            if (std::abs(p[0]) <= tol)
              lo = std::min(lo, p[1]), hi = std::max(hi, p[1]);
          g.clamp_y_m = {lo, hi};
        }
    }

    /// [[port]] table k: a circle (center_m, diameter_m) or a polygon.
    Port read_port(const CaseFile &f, std::size_t k, const ValveGeometry &g)
    {
      const Bounds pos = Bounds::positive();
      const std::string pt = port_table(k);
      Port              p;
      p.length_m         = f.real(pt, "length_m", g.port_length_m, pos);
      const bool circle  = f.has(pt, "diameter_m") || f.has(pt, "center_m");
      const bool polygon = f.has(pt, "outline_m") || f.has(pt, "outline_csv");
      if (circle == polygon)
        throw InputError(f.where(pt, circle ? "outline_m" : "diameter_m") +
                         ": a port is a circle (center_m and diameter_m) or a polygon (outline_m or outline_csv)" +
                         (circle ? ", not both" : ""));
      f.declare(pt, "diameter_m"), f.declare(pt, "center_m"), f.declare(pt, "outline_m"), f.declare(pt, "outline_csv");
      if (circle)
        {
          p.circular = true;
          for (const std::string key : {"diameter_m", "center_m"})
            if (!f.has(pt, key))
              throw InputError(f.where(pt, key) + ": missing; a circular port needs center_m = [x, y] and diameter_m");
          p.diameter_m      = f.real(pt, "diameter_m", 0.0, pos);
          const auto centre = f.reals(pt, "center_m", {}, Bounds());
          if (centre.size() != 2)
            throw InputError(f.where(pt, "center_m") + ": expected one point [x, y], got " +
                             std::to_string(centre.size()) + " numbers");
          p.center_m = {centre[0], centre[1]};
        }
      else
        {
          p.circular  = false;
          p.outline_m = read_outline(f, pt, "outline");
          if (p.outline_m.size() >= 3 && !geometry::first_self_intersection(p.outline_m))
            p.outline_m = counter_clockwise(p.outline_m);
        }
      return p;
    }
  } // namespace

  ValveGeometry ValveGeometry::from_case(const CaseFile &f)
  {
    ValveGeometry     g;
    const std::string t   = "geometry";
    const Bounds      pos = Bounds::positive();
    const bool outline = f.has(t, "reed_outline_m") || f.has(t, "reed_outline_csv");
    const std::size_t n_ports = f.table_count("port");
    check_either_or(f, t, outline, n_ports);
    g.reed_thickness_m = f.real(t, "reed_thickness_m", g.reed_thickness_m, pos);
    g.port_length_m    = f.real(t, "port_length_m", g.port_length_m, pos);
    g.pocket_length_m  = f.real(t, "pocket_length_m", g.pocket_length_m, pos);
    g.pocket_width_m   = f.real(t, "pocket_width_m", g.pocket_width_m, pos);
    g.pocket_height_m  = f.real(t, "pocket_height_m", g.pocket_height_m, pos);
    g.outlet_face      = f.text(t, "outlet_face", g.outlet_face, {"x-max", "y-min", "y-max", "ceiling"});
    g.seat_land_min_m  = f.real(t, "seat_land_min_m", g.seat_land_min_m, pos);
    if (f.has(t, "stop_height_m"))
      g.stop_height_m = f.real(t, "stop_height_m", 0.0, Bounds::positive());
    else
      f.declare(t, "stop_height_m");

    if (!outline)
      {
        g.reed_length_m = f.real(t, "reed_length_m", g.reed_length_m, pos);
        g.reed_width_m  = f.real(t, "reed_width_m", g.reed_width_m, pos);
      }
    else
      {
        read_reed_outline(f, t, g);
      }

    if (n_ports == 0)
      {
        g.port_diameter_m = f.real(t, "port_diameter_m", g.port_diameter_m, pos);
        g.port_center_x_m = f.real(t, "port_center_x_m", g.port_center_x_m, pos);
      }
    for (std::size_t k = 0; k < n_ports; ++k)
      {
        g.port_list.push_back(read_port(f, k, g));
      }

    // The shorthand's fields for an outline: its bounding box, its first port.
    if (!g.reed_outline_m.empty())
      {
        double x_max = 0, y_min = std::numeric_limits<double>::infinity(), y_max = -y_min;
        for (const XY &p : g.reed_outline_m)
          x_max = std::max(x_max, p[0]), y_min = std::min(y_min, p[1]), y_max = std::max(y_max, p[1]);
        g.reed_length_m = x_max;
        g.reed_width_m  = y_max - y_min;
      }
    if (!g.port_list.empty())
      {
        const Port &p     = g.port_list.front();
        g.port_diameter_m = std::sqrt(4 * p.area_m2() / M_PI);
        g.port_center_x_m = p.centroid_m()[0];
        g.port_length_m   = p.length_m;
      }
    check_geometry(g, [&](const std::string &table, const std::string &key) { return f.where(table, key); });
    return g;
  }
} // namespace rectify
