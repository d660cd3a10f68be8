#include "mesher/parameters.h"

#include <cmath>
#include <cstdlib>

namespace rectify::mesher
{
  MeshSettings MeshSettings::from_case(const CaseFile &f)
  {
    MeshSettings      s;
    const std::string t   = "mesh";
    const Bounds      pos = Bounds::positive();
    s.shape = f.text(t, "shape", s.shape, {"beam", "table"});
    if (f.has(t, "shape_table"))
      s.shape_table = f.resolve(f.text(t, "shape_table", ""));
    if (s.shape == "table" && s.shape_table.empty())
      throw InputError(f.where(t, "shape") + " = \"table\" needs shape_table (a CSV with s_m, phi)");
    s.size_reed_m       = f.real(t, "size_reed_m", s.size_reed_m, pos);
    s.size_far_m        = f.real(t, "size_far_m", s.size_far_m, pos);
    s.size_growth       = f.real(t, "size_growth", s.size_growth, Bounds::closed(0.05, 2.0));
    s.station_spacing_m = f.real(t, "station_spacing_m", s.station_spacing_m, pos);
    s.port_segments     = f.integer(t, "port_segments", s.port_segments, 0, 4096);
    if (s.port_segments != 0 && s.port_segments < 8)
      throw InputError(f.where(t, "port_segments") + " = " + std::to_string(s.port_segments) +
                       ": at least 8 (or 0 for automatic)");
    s.gap_layers       = f.integer(t, "gap_layers", s.gap_layers, 1, 64);
    s.reed_layers      = f.integer(t, "reed_layers", s.reed_layers, 1, 64);
    s.above_layers     = f.integer(t, "above_layers", s.above_layers, 1, 64);
    s.slab_margin_m    = f.real(t, "slab_margin_m", s.slab_margin_m, pos);
    s.min_slab_margin_m = f.real(t, "min_slab_margin_m", s.min_slab_margin_m, pos);
    s.blend_distance_m = f.real(t, "blend_distance_m", s.blend_distance_m, pos);
    s.port_layer_m     = f.real(t, "port_layer_m", s.port_layer_m, pos);
    s.gap_cutoff_ratio = f.real(t, "gap_cutoff_ratio", s.gap_cutoff_ratio, Bounds::open(0.0, 0.5));
    s.min_angle_deg    = f.real(t, "min_angle_deg", s.min_angle_deg, Bounds::closed(5.0, 30.0));
    s.tetgen_radius_edge_ratio =
      f.real(t, "tetgen_radius_edge_ratio", s.tetgen_radius_edge_ratio, Bounds::closed(1.1, 10.0));
    s.tetgen_min_dihedral_deg =
      f.real(t, "tetgen_min_dihedral_deg", s.tetgen_min_dihedral_deg, Bounds::closed(0.0, 20.0));
    s.tetgen_max_volume_m3 =
      f.real(t, "tetgen_max_volume_m3", s.tetgen_max_volume_m3, Bounds::non_negative());
    if (s.size_far_m < s.size_reed_m)
      throw InputError(f.where(t, "size_far_m") + " = " + format_number(s.size_far_m) +
                       ": must not be smaller than size_reed_m = " + format_number(s.size_reed_m));
    return s;
  }

  MeshParameters MeshParameters::from_case(const CaseFile &file)
  {
    MeshParameters p{ValveGeometry::from_case(file), MeshSettings::from_case(file)};
    const auto    &g = p.geometry;
    const auto    &s = p.settings;
    const double   size_limit = 0.25 * std::min(g.reed_width_m, g.port_diameter_m);
    if (s.size_reed_m > size_limit)
      throw InputError(file.where("mesh", "size_reed_m") + " = " + format_number(s.size_reed_m) +
                       ": too coarse to resolve the port and the reed (at most a quarter of the"
                       " port's diameter and the reed's width, " + format_number(size_limit) + " m)");
    for (const auto &feature : g.features())
      if (feature.size_m < s.size_reed_m)
        throw InputError(file.where("mesh", "size_reed_m") + " = " + format_number(s.size_reed_m) +
                         ": coarser than " + feature.what + " (" + format_number(feature.size_m) +
                         " m), which the mesh could not resolve; make size_reed_m at most that, or the feature larger");
    if (s.min_slab_margin_m > s.slab_margin_m)
      throw InputError(file.where("mesh", "min_slab_margin_m") + " = " + format_number(s.min_slab_margin_m) +
                       ": above slab_margin_m = " + format_number(s.slab_margin_m));
    if (2 * s.slab_margin_m + g.reed_thickness_m >= g.pocket_height_m)
      throw InputError(file.where("mesh", "slab_margin_m") + " = " + format_number(s.slab_margin_m) +
                       ": the slab (reed thickness + 2 margins) does not fit under the pocket"
                       " ceiling (pocket_height_m = " + format_number(g.pocket_height_m) + ")");
    if (s.shape == "table")
      (void)p.reed_shape(); // check the table now, before any meshing
    return p;
  }

  double MeshParameters::slab_margin_at(double opening_m) const
  {
    const double room = geometry.pocket_height_m - geometry.reed_thickness_m - opening_m;
    return std::min(settings.slab_margin_m, 0.5 * room);
  }

  double MeshParameters::ceiling_reach_m() const
  {
    return geometry.pocket_height_m - geometry.reed_thickness_m - 2.0 * settings.min_slab_margin_m;
  }

  std::size_t cutoff_station(const SampledShape &shape, double cutoff_ratio, double opening_m, double thickness_m)
  {
    const auto &phi = shape.values();
    std::size_t j   = 1;
    while (j + 1 < phi.size() && phi[j] < cutoff_ratio)
      ++j;
    while (j > 1 && opening_m * phi[j] >= 0.9 * thickness_m)
      --j;
    return j;
  }

  double MeshParameters::cutoff_reach_m() const
  {
    return 0.9 * geometry.reed_thickness_m / sampled_shape().values()[1];
  }

  double MeshParameters::max_opening_m() const { return std::min(ceiling_reach_m(), cutoff_reach_m()); }

  std::string MeshParameters::reach_limit() const
  {
    if (ceiling_reach_m() <= cutoff_reach_m())
      return "the mesher needs 2 x [mesh] min_slab_margin_m between the reed's tip and the pocket's ceiling"
             " (a smaller min_slab_margin_m reaches further, with thinner cells there)";
    return "the gap the mesher treats as closed (the opening x the shape at its first station off the clamp) "
           "must stay below 0.9 of the reed's thickness (" + format_number(geometry.reed_thickness_m) +
           " m); a finer [mesh] station_spacing_m reaches further";
  }

  ReedShape MeshParameters::reed_shape() const
  {
    if (settings.shape == "table")
      return ReedShape::from_csv(settings.shape_table, geometry.reed_length_m);
    return ReedShape::beam(geometry.reed_length_m, geometry.port_center_x_m);
  }

  SampledShape MeshParameters::sampled_shape() const
  {
    const double c = geometry.port_center_x_m, r = 0.5 * geometry.port_diameter_m;
    return SampledShape(reed_shape(), settings.station_spacing_m, {c - r, c + r});
  }

  double seat_film_modal_area_m2(const ValveGeometry &g, const std::function<double(double)> &shape)
  {
    // Footprint: W times the integral of phi along the reed (Gauss, 2 points
    // on 4000 panels: exact for the sampled shape's linear pieces up to the
    // panels that hold a station). Port: s = c + r sin(theta), its chord
    // 2 r cos(theta) (at most W), ds = r cos(theta) dtheta: smooth in theta.
    if (!g.is_shorthand())
      {
        // Any outline and ports: phi(s) times the seat's chord at s (the
        // reed's chord less the ports'), Gauss with 2 points on 20 000 panels.
        const auto   outline = g.reed_boundary();
        const auto   ports   = g.ports();
        const double L = g.reed_length_m, h = L / 20000, gp = 0.5 / std::sqrt(3.0);
        const auto   seat = [&](double x) {
          double w = geometry::chord_width(outline, x);
          for (const auto &port : ports)
            if (port.circular)
              {
                const double r = 0.5 * port.diameter_m, d = x - port.center_m[0];
                w -= d * d < r * r ? 2 * std::sqrt(r * r - d * d) : 0.0;
              }
            else
              w -= geometry::chord_width(port.outline_m, x);
          return w;
        };
        double area = 0;
        for (int k = 0; k < 20000; ++k)
          for (const double q : {(k + 0.5 - gp) * h, (k + 0.5 + gp) * h})
            area += 0.5 * h * shape(q) * seat(q);
        return area;
      }
    const double L = g.reed_length_m, W = g.reed_width_m, c = g.port_center_x_m, r = 0.5 * g.port_diameter_m;
    const int    n = 4000;
    const double h = L / n, gp = 0.5 / std::sqrt(3.0);
    double       footprint = 0;
    for (int k = 0; k < n; ++k)
      footprint += 0.5 * h * (shape((k + 0.5 - gp) * h) + shape((k + 0.5 + gp) * h));
    double port = 0;
    const double dt = M_PI / n;
    for (int k = 0; k < n; ++k)
      {
        const double t = -0.5 * M_PI + (k + 0.5) * dt;
        port += shape(c + r * std::sin(t)) * std::min(2 * r * std::cos(t), W) * r * std::cos(t) * dt;
      }
    return W * footprint - port;
  }

  double parse_length(const std::string &text, const std::string &what)
  {
    const char *begin = text.c_str();
    char       *end   = nullptr;
    const double value = std::strtod(begin, &end);
    const std::string unit = std::string(end);
    double scale = 0;
    if (end == begin)
      scale = 0;
    else if (unit.empty() || unit == "m")
      scale = 1;
    else if (unit == "mm")
      scale = 1e-3;
    else if (unit == "um" || unit == "µm")
      scale = 1e-6;
    else if (unit == "nm")
      scale = 1e-9;
    if (scale == 0 || !std::isfinite(value) || !(value > 0))
      throw InputError(what + " = \"" + text +
                       "\": expected a positive length in metres, or with a unit (m, mm, um):"
                       " 2e-6, 100um, 1.21mm");
    return value * scale;
  }

  nlohmann::json MeshSettings::to_json() const
  {
    return {{"shape", shape},
            {"shape_table", shape_table.string()},
            {"size_reed_m", size_reed_m},
            {"size_far_m", size_far_m},
            {"size_growth", size_growth},
            {"station_spacing_m", station_spacing_m},
            {"port_segments", port_segments},
            {"gap_layers", gap_layers},
            {"reed_layers", reed_layers},
            {"above_layers", above_layers},
            {"slab_margin_m", slab_margin_m},
            {"min_slab_margin_m", min_slab_margin_m},
            {"blend_distance_m", blend_distance_m},
            {"port_layer_m", port_layer_m},
            {"gap_cutoff_ratio", gap_cutoff_ratio},
            {"min_angle_deg", min_angle_deg},
            {"tetgen_radius_edge_ratio", tetgen_radius_edge_ratio},
            {"tetgen_min_dihedral_deg", tetgen_min_dihedral_deg},
            {"tetgen_max_volume_m3", tetgen_max_volume_m3}};
  }
} // namespace rectify::mesher
