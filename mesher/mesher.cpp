#include "mesher/mesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "mesher/layout.h"

namespace rectify::mesher
{
  using namespace detail;

  namespace
  {
    using Clock = std::chrono::steady_clock;

    /// The tip opening must be positive, resolvable by the layered gap, and
    /// leave the reed inside its pocket with room for the slab's margin.
    void check_opening(const MeshParameters &parameters, double opening)
    {
      const auto &g = parameters.geometry;
      const auto &s = parameters.settings;
      if (!std::isfinite(opening) || !(opening > 0))
        throw InputError("tip opening = " + format_number(opening) + " m: must be positive");
      // The gap under the reed is layered: its cells are about size_reed_m wide
      // and opening / gap_layers high (at 2 um, the reference map's first
      // opening, 300:1 by that estimate, 2300:1 measured). Flatter than
      // 10^4:1 (60 nm for the reference settings) the mesh degenerates (at
      // 1e-12 m: aspect ratio 4.6e9, dihedral angles of 0 degrees) and nothing
      // shows the solution still holds: refused.
      const double min_opening = s.size_reed_m * static_cast<double>(s.gap_layers) / 1e4;
      if (opening < min_opening)
        throw InputError("tip opening = " + format_number(opening) + " m: below the smallest opening the mesh resolves, " +
                         format_number(min_opening) + " m ([mesh] size_reed_m x gap_layers / 10^4: gap cells flatter than "
                         "10^4:1); a valve this nearly closed is the map's closed resistance");
      if (opening + g.reed_thickness_m >= g.pocket_height_m)
        throw InputError("tip opening = " + format_number(opening) +
                         " m would push the reed through the pocket ceiling: its tip's top at " +
                         format_number(opening + g.reed_thickness_m) +
                         " m, [geometry] pocket_height_m = " + format_number(g.pocket_height_m));
      if (opening > parameters.ceiling_reach_m())
        throw InputError("tip opening = " + format_number(opening) + " m leaves " +
                         format_number(g.pocket_height_m - opening - g.reed_thickness_m) +
                         " m above the reed's tip; the mesher needs 2 x [mesh] min_slab_margin_m = " +
                         format_number(2 * s.min_slab_margin_m) + " m there: it reaches " +
                         format_number(parameters.ceiling_reach_m()) + " m (lower min_slab_margin_m)");
    }

    /// The gap treated as closed must be thinner than the reed and stop short of every port.
    void check_cutoff(const MeshParameters &parameters, const Layout &lay, double opening)
    {
      const auto &s = parameters.settings;
      if (lay.h_cut >= 0.9 * lay.t)
        throw InputError("[mesh] gap_cutoff_ratio = " + format_number(s.gap_cutoff_ratio) +
                         ": at tip opening " + format_number(opening) + " m the cut-off gap (" +
                         format_number(lay.h_cut) + " m) is not thinner than the reed even at the shape's first "
                         "station; this reed's mesh reaches " + format_number(parameters.cutoff_reach_m()) + " m");
      for (const auto &port : lay.ports)
        {
          double x_min = port.center_m[0] - 1.01 * 0.5 * port.diameter_m; // a circle's polygon reaches past r
          if (!port.circular)
            {
              x_min = port.outline_m.front()[0];
              for (const auto &q : port.outline_m)
                x_min = std::min(x_min, q[0]);
            }
          if (x_min <= lay.x_closed + 0.5 * s.size_reed_m)
            throw InputError("[mesh] gap_cutoff_ratio = " + format_number(s.gap_cutoff_ratio) +
                             ": the gap treated as closed (up to " + format_number(lay.x_closed) +
                             " m from the clamp line) reaches a port; lower it");
        }
    }

    /// The floor under the reed is the reed's outline, to rounding.
    void check_floor_follows_outline(const Layout &lay, const PlanarMesh &floor, const std::vector<FloorPart> &parts)
    {
      double under = 0;
      for (std::size_t f = 0; f < floor.triangles.size(); ++f)
        if (parts[f] != FloorPart::outside)
          {
            const auto &a = floor.points[floor.triangles[f][0]], &b = floor.points[floor.triangles[f][1]],
                       &c = floor.points[floor.triangles[f][2]];
            under += 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]));
          }
      const double area = std::abs(geometry::signed_area(lay.outline));
      if (std::abs(under - area) > 1e-9 * area)
        throw MeshError("the floor triangulation does not follow the reed's outline: " + format_number(under) +
                        " m^2 under the reed for an outline of " + format_number(area) + " m^2");
    }

    /// The fluid's and the gap's exact volumes for the mesh's checks.
    void set_exact_volumes(const Layout &lay, const std::vector<PortPolygon> &polygons, double opening, MeshInfo &info)
    {
      // The exact volumes: the gap under the reed is opening x phi(s) over its
      // chord w(s); phi is linear between stations, w between the outline's
      // corners, so phi w is quadratic between their union: Simpson is exact.
      double ports_volume = 0, ports_area = 0;
      for (const auto &poly : polygons)
        ports_volume += poly.area() * poly.length, ports_area += poly.area();
      double closed_integral = 0, reed_integral = 0;
      if (lay.rectangle)
        {
          closed_integral = lay.W * lay.shape.integral_to_station(lay.j_closed);
          reed_integral   = lay.W * lay.shape.integral_to_station(lay.shape.stations().size() - 1);
        }
      else
        {
          std::vector<double> breaks = lay.shape.stations();
          for (const auto &q : lay.outline)
            breaks.push_back(std::clamp(q[0], 0.0, lay.L));
          std::sort(breaks.begin(), breaks.end());
          const auto chord = [&](double x) {
            return geometry::chord_width(lay.outline, std::clamp(x, 1e-12 * lay.L, (1 - 1e-12) * lay.L));
          };
          for (std::size_t k = 1; k < breaks.size(); ++k)
            {
              const double a = breaks[k - 1], b = breaks[k];
              if (!(b > a))
                continue;
              const auto   f = [&](double x) { return lay.shape(x) * chord(x); };
              // inside the interval, away from the corners where chord() jumps
              const double e = 1e-9 * (b - a);
              const double simpson = (b - a) / 6 * (f(a + e) + 4 * f(0.5 * (a + b)) + f(b - e));
              reed_integral += simpson;
              if (b <= lay.x_closed + 1e-12 * lay.L)
                closed_integral += simpson;
            }
        }
      info.exact_fluid_volume_m3 = lay.Lp * lay.Wp * lay.Hp + ports_volume -
                                   std::abs(geometry::signed_area(lay.outline)) * lay.t - opening * closed_integral;
      info.exact_gap_volume_m3   = opening * (reed_integral - closed_integral);
      info.exact_inlet_area_m2   = ports_area;
    }

    /// The fluid's boundary is closed, not self-intersecting, outward, and carries every id.
    void check_boundary(const MeshInfo &info)
    {
      if (!info.surface.closed || info.surface.self_intersecting || !info.surface.outward)
        throw MeshError(std::string("the fluid's boundary is ") +
                        (!info.surface.closed ? "not a closed manifold surface"
                         : info.surface.self_intersecting ? "self-intersecting"
                                                          : "not oriented outwards"));
      for (int id = inlet; id <= reed; ++id)
        if (info.boundary_faces[id] == 0)
          throw MeshError("no boundary face carries id " + std::to_string(id) + " (" +
                          boundary_name(static_cast<std::uint8_t>(id)) + ")");
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
    check_opening(parameters, opening);

    // Near the ceiling the slab's margin above the reed shrinks to half the
    // room left, so that TetGen's pocket keeps as much.
    MeshParameters local = parameters;
    local.settings.slab_margin_m = parameters.slab_margin_at(opening);
    info.slab_margin_m           = local.settings.slab_margin_m;
    const Layout lay(local, opening);
    check_cutoff(parameters, lay, opening);

    // 1. The floor.
    const auto       polygons = lay.port_polygons();
    const PlanarMesh floor    = mesh_floor(lay, polygons);
    std::vector<int> port_of;
    const auto       parts = classify_floor(lay, floor, polygons, port_of);
    info.n_floor_triangles    = floor.triangles.size();
    check_floor_follows_outline(lay, floor, parts);
    lap("floor triangulation (CGAL)");

    // 2. The layered slab and 3. the port.
    TetMesh all;
    build_slab(lay, floor, parts, all);
    lap("layered slab");
    build_port(lay, floor, parts, port_of, polygons, all);
    lap("port extrusion");

    // 4. The pocket above the slab (TetGen).
    const std::size_t n_layered = all.cells.size();
    info.tetgen_switches        = build_pocket(lay, floor, all);
    info.n_bulk_cells           = all.cells.size() - n_layered;
    lap("pocket surface and tetrahedra (CGAL, TetGen)");

    // 5. Orientation, boundary ids; the fluid cells only.
    result.mesh          = assemble_fluid(all, lay, polygons);
    const TetMesh &mesh  = result.mesh;
    lap("orientation and boundary ids");

    // 7. Checks and numbers.
    info.opening_m            = opening;
    info.n_vertices           = mesh.vertices.size();
    info.shape                = parameters.settings.shape;
    info.gap_layers           = lay.Ng;
    info.port_segments        = 0;
    for (const auto &poly : polygons)
      info.port_segments += poly.points.size();
    info.n_stations           = lay.shape.stations().size();
    info.closed_to_m          = lay.x_closed;
    info.cutoff_thickness_m   = lay.h_cut;
    info.shape_sampling_error = lay.shape.max_sampling_error();
    info.quality              = measure_quality(mesh);
    info.quality.min_floor_angle_deg = min_angle_deg(floor);
    info.fluid_volume_m3      = info.quality.all.volume_m3;
    info.gap_volume_m3        = info.quality.region[gap].volume_m3;
    set_exact_volumes(lay, polygons, opening, info);
    for (const auto &f : mesh.boundary)
      {
        ++info.boundary_faces[f.id];
        info.boundary_area_m2[f.id] += triangle_area(mesh.vertices[f.vertices[0]],
                                                     mesh.vertices[f.vertices[1]],
                                                     mesh.vertices[f.vertices[2]]);
      }
    info.exact_outlet_area_m2 = g.outlet_area_m2();
    info.surface              = check_surface(mesh);
    lap("checks (CGAL surface, quality)");
    info.wall_time_s = std::chrono::duration<double>(Clock::now() - start).count();

    check_boundary(info);
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
      {"slab_margin_m", i.slab_margin_m},
      {"gap", {{"volume_m3", i.gap_volume_m3},
               {"exact_volume_m3", i.exact_gap_volume_m3},
               {"thinnest_open_gap_m", i.cutoff_thickness_m},
               {"thinnest_layer_m", i.cutoff_thickness_m / static_cast<double>(i.gap_layers)}}},
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
