// The reed valve's geometry, shared by the mesher, the Stokes solver and the
// stiffness solver: case table [geometry] and the [[port]] tables
// (reference-case.md sec. 1; docs/geometry.md).
// Coordinates: x from the clamp line along the reed, y across it, z in the
// opening direction, z = 0 on the seat plane. The clamp line lies on the
// pocket's wall x = 0.
//
// Two ways to write it, one description:
// - the shorthand: a rectangular reed reed_length_m x reed_width_m centred
//   on y = 0 over one circular port (port_diameter_m at port_center_x_m);
// - the outline: the reed as a closed polygon (reed_outline_m or
//   reed_outline_csv) with optional fillet radii at its corners, its clamp
//   line an edge on x = 0, and any number of ports ([[port]]: circles or
//   polygons).
// The shorthand's fields stay filled for an outline (its bounding box, its
// first port), so that code written for the rectangle reads them; code that
// needs the shape asks for reed_boundary() and ports().
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/case_file.h"
#include "common/polygon.h"

namespace rectify
{
  /// One port: the hole through the seat under the reed, from the inlet face
  /// z = -length_m to the seat z = 0.
  struct Port
  {
    bool              circular   = true;
    geometry::XY      center_m   = {3.3e-3, 0.0}; ///< a circle's centre
    double            diameter_m = 3.175e-3;      ///< a circle's diameter
    geometry::Polygon outline_m;                  ///< a polygon port's outline, counter-clockwise
    double            length_m = 3.0e-3;

    double area_m2() const;
    double perimeter_m() const;
    /// The mouth as a polygon: the outline, or the circle as `circle_sides`
    /// sides of the same area.
    geometry::Polygon polygon(std::size_t circle_sides = 96) const;
    /// Centre of the mouth's area.
    geometry::XY centroid_m() const;
    bool         contains(const geometry::XY &p) const;
    /// Distance from p to the port's edge.
    double distance_to_edge(const geometry::XY &p) const;
    /// The seat land the reed `reed` (its boundary) leaves around the port:
    /// the least distance from the port's edge to the reed's (negative if it pokes out).
    double land_under(const geometry::Polygon &reed) const;
    /// 4 area / perimeter.
    double hydraulic_diameter_m() const;
    nlohmann::json to_json() const;
  };

  /// A length in the geometry that a mesh must resolve, and what it is.
  struct GeometryFeature
  {
    double      size_m = 0;
    std::string what;
  };

  struct ValveGeometry
  {
    double reed_length_m    = 6.1e-3;   ///< L, clamp line to tip (0.240 in)
    double reed_width_m     = 5.08e-3;  ///< 0.200 in, centred on y = 0
    double reed_thickness_m = 0.127e-3; ///< 0.005 in
    double port_diameter_m  = 3.175e-3; ///< 0.125 in
    double port_center_x_m  = 3.3e-3;   ///< port axis, distance from the clamp line
    double port_length_m    = 3.0e-3;   ///< from the inlet face z = -length to the seat z = 0
    /// The pocket on the outlet side: the box [0, length] x [-width/2, width/2]
    /// x [0, height]; the clamp line lies on its wall x = 0.
    double pocket_length_m = 9.0e-3;
    double pocket_width_m  = 8.0e-3;
    double pocket_height_m = 2.0e-3;
    /// Which pocket face is the outlet: "x-max" (reference), "y-min", "y-max"
    /// or "ceiling". The inlet is the port's face z = -port_length_m.
    std::string outlet_face = "x-max";
    /// The stop (guard) that limits the reed's lift: the height of its face
    /// above the seat plane, in (reed_thickness_m, pocket_height_m]; NaN
    /// (the key left out): the pocket's ceiling is the stop. The reed's top
    /// meets it at the tip opening stop_lift_m(). A flat stop over the
    /// whole reed; not part of the flow domain (the map sets mesh the open
    /// pocket), so not in to_json() (a map set's provenance).
    double stop_height_m = std::numeric_limits<double>::quiet_NaN();
    /// The stop face's height: stop_height_m, or the ceiling.
    double stop_face_m() const { return std::isnan(stop_height_m) ? pocket_height_m : stop_height_m; }
    /// The tip opening at which the reed meets its stop: the stop's face
    /// less the reed's thickness (by default the ceiling less the thickness).
    double stop_lift_m() const { return stop_face_m() - reed_thickness_m; }

    /// The outline (empty: the shorthand's rectangle): corners,
    /// counter-clockwise, as written.
    geometry::Polygon   reed_outline_m;
    std::vector<double> reed_fillet_radii_m; ///< per corner of reed_outline_m (0: sharp)
    /// The clamp line, from (0, y0) to (0, y1), y0 < y1 (outline only).
    std::array<double, 2> clamp_y_m = {0.0, 0.0};
    /// The ports (empty: the shorthand's one circle).
    std::vector<Port> port_list;
    /// The narrowest seat land a port may have: the reed must cover each port
    /// with at least this much seat around it, and ports must be this far apart.
    double seat_land_min_m = 0.2e-3;

    /// True if written as the shorthand (no outline, no [[port]]).
    bool is_shorthand() const { return reed_outline_m.empty() && port_list.empty(); }
    /// The reed's corners as written (the shorthand: its rectangle), counter-clockwise.
    geometry::Polygon reed_corners() const;
    /// The fillet radius of each corner of reed_corners().
    std::vector<double> fillet_radii() const;
    /// The reed's outline with its fillets, arcs in steps of at most 5 degrees.
    geometry::Polygon reed_boundary() const;
    /// The clamp line's ends on x = 0.
    std::array<double, 2> clamp_line_y() const;
    std::vector<Port>     ports() const;
    double                reed_area_m2() const;
    /// Total port area.
    double ports_area_m2() const;

    /// The narrowest seat land: over every port, the smallest distance from
    /// its edge to the reed's outline.
    double seat_land_m() const;
    /// The lengths a mesh must resolve, smallest first: straight edges left
    /// between fillets, fillet radii, narrowest widths, ports' sizes, seat
    /// lands, gaps between ports.
    std::vector<GeometryFeature> features() const;

    /// Area of the outlet face [m^2].
    double outlet_area_m2() const;

    /// Every check of from_case on a geometry built in code; throws
    /// InputError (`where` names its source).
    void check(const std::string &where) const;

    /// The description as summaries and map sets record it. The shorthand
    /// gives its ten keys as always (a map set's hash does not change); an
    /// outline adds the outline, fillets, clamp line and ports.
    nlohmann::json to_json() const;

    /// Reads and checks [geometry] and [[port]]: the outline simple, the
    /// clamp line an edge on x = 0, each port covered by the reed with a
    /// seat land of at least seat_land_min_m, ports apart, the reed inside the
    /// pocket and thin; otherwise an InputError naming the key and value.
    static ValveGeometry from_case(const CaseFile &file);
  };
} // namespace rectify
