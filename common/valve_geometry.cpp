#include "common/valve_geometry.h"

#include <algorithm>

namespace rectify
{
  ValveGeometry ValveGeometry::from_case(const CaseFile &f)
  {
    ValveGeometry     g;
    const std::string t   = "geometry";
    const Bounds      pos = Bounds::positive();
    g.reed_length_m    = f.real(t, "reed_length_m", g.reed_length_m, pos);
    g.reed_width_m     = f.real(t, "reed_width_m", g.reed_width_m, pos);
    g.reed_thickness_m = f.real(t, "reed_thickness_m", g.reed_thickness_m, pos);
    g.port_diameter_m  = f.real(t, "port_diameter_m", g.port_diameter_m, pos);
    g.port_center_x_m  = f.real(t, "port_center_x_m", g.port_center_x_m, pos);
    g.port_length_m    = f.real(t, "port_length_m", g.port_length_m, pos);
    g.pocket_length_m  = f.real(t, "pocket_length_m", g.pocket_length_m, pos);
    g.pocket_width_m   = f.real(t, "pocket_width_m", g.pocket_width_m, pos);
    g.pocket_height_m  = f.real(t, "pocket_height_m", g.pocket_height_m, pos);
    g.outlet_face = f.text(t, "outlet_face", g.outlet_face, {"x-max", "y-min", "y-max", "ceiling"});

    const double r = 0.5 * g.port_diameter_m;
    if (g.port_center_x_m - r <= 0.0 || g.port_center_x_m + r >= g.pocket_length_m ||
        r >= 0.5 * g.pocket_width_m)
      throw InputError(f.where(t, "port_center_x_m") + " = " + format_number(g.port_center_x_m) +
                       " with port_diameter_m = " + format_number(g.port_diameter_m) +
                       ": the port lies outside the seat (the pocket floor [0, " +
                       format_number(g.pocket_length_m) + "] x [-" +
                       format_number(0.5 * g.pocket_width_m) + ", " +
                       format_number(0.5 * g.pocket_width_m) + "] m)");
    if (g.reed_length_m >= g.pocket_length_m)
      throw InputError(f.where(t, "reed_length_m") + " = " + format_number(g.reed_length_m) +
                       ": the reed must end inside the pocket (pocket_length_m = " +
                       format_number(g.pocket_length_m) + ")");
    if (g.reed_width_m >= g.pocket_width_m)
      throw InputError(f.where(t, "reed_width_m") + " = " + format_number(g.reed_width_m) +
                       ": the reed must fit inside the pocket (pocket_width_m = " +
                       format_number(g.pocket_width_m) + ")");
    if (g.reed_thickness_m >= g.pocket_height_m)
      throw InputError(f.where(t, "reed_thickness_m") + " = " + format_number(g.reed_thickness_m) +
                       ": the closed reed would not fit under the pocket ceiling (pocket_height_m = " +
                       format_number(g.pocket_height_m) + ")");
    if (g.port_center_x_m - r <= 0.0 || g.port_center_x_m + r >= g.reed_length_m ||
        r >= 0.5 * g.reed_width_m)
      throw InputError(f.where(t, "port_diameter_m") + " = " + format_number(g.port_diameter_m) +
                       " with port_center_x_m = " + format_number(g.port_center_x_m) +
                       ": the reed (" + format_number(g.reed_length_m) + " x " +
                       format_number(g.reed_width_m) +
                       " m from the clamp line) does not cover its port");
    if (g.reed_thickness_m >= 0.5 * std::min(g.reed_length_m, g.reed_width_m))
      throw InputError(f.where(t, "reed_thickness_m") + " = " + format_number(g.reed_thickness_m) +
                       ": a reed must be a thin plate (thickness below half its length and width)");
    return g;
  }

  double ValveGeometry::outlet_area_m2() const
  {
    if (outlet_face == "ceiling")
      return pocket_length_m * pocket_width_m;
    if (outlet_face == "x-max")
      return pocket_width_m * pocket_height_m;
    return pocket_length_m * pocket_height_m;
  }
} // namespace rectify
