// The mesher's settings: case table [mesh]. The geometry is [geometry]
// (common/valve_geometry.h).
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <string>

#include "common/case_file.h"
#include "common/valve_geometry.h"
#include "mesher/shape.h"

namespace rectify::mesher
{
  struct MeshSettings
  {
    std::string           shape = "beam"; ///< "beam" (reference) or "table"
    std::filesystem::path shape_table;    ///< CSV with s_m, phi (shape = "table")

    double size_reed_m      = 0.30e-3; ///< in-plane cell size over the reed and the port
    double size_far_m       = 0.9e-3;  ///< in-plane cell size far from the reed
    double size_growth      = 0.3;     ///< size grows by this times the distance from the reed
    double station_spacing_m = 0.25e-3; ///< the reed's shape is sampled at least this finely
    long   port_segments    = 0;       ///< sides of the port polygon (0: from size_reed_m)
    long   gap_layers       = 2;       ///< element layers across the gap under the reed
    long   reed_layers      = 1;       ///< layers beside the reed's thickness
    long   above_layers     = 1;       ///< layers between the reed's top and the slab's top
    double slab_margin_m    = 0.15e-3; ///< slab top above the reed's top
    /// Near the ceiling the slab's margin shrinks to half the room above the
    /// reed's tip, down to this: the mesher's reach is the opening where the
    /// room is twice it.
    double min_slab_margin_m = 10e-6;
    double blend_distance_m = 1.0e-3;  ///< layers relax to uniform over this distance from the reed
    double port_layer_m     = 0.6e-3;  ///< layer thickness in the port
    double gap_cutoff_ratio = 0.05;    ///< gap thinner than this times the opening: closed
    double min_angle_deg    = 25.0;    ///< smallest angle of the floor and wall triangles
    double tetgen_radius_edge_ratio = 1.5; ///< TetGen -q: radius-edge ratio bound
    double tetgen_min_dihedral_deg  = 12.0; ///< TetGen -q: dihedral angle bound
    double tetgen_max_volume_m3     = 0.0;  ///< TetGen -a (0: none)

    /// Every setting, as `rectify check` and the map sets record them.
    nlohmann::json to_json() const;
    static MeshSettings from_case(const CaseFile &file);
  };

  /// Everything the mesher needs from a case file.
  struct MeshParameters
  {
    ValveGeometry geometry;
    MeshSettings  settings;
    static MeshParameters from_case(const CaseFile &file);
    /// The reed shape the settings name (reads the table if any).
    ReedShape reed_shape() const;
    /// The shape as the mesh holds it: sampled on stations at most
    /// station_spacing_m apart, none grazing the port's edge.
    SampledShape sampled_shape() const;
    /// The slab's margin above the reed's top at a tip opening: slab_margin_m,
    /// or half the room left between the reed's tip and the ceiling where
    /// that is less (never below min_slab_margin_m at openings up to
    /// max_opening_m()).
    double slab_margin_at(double opening_m) const;
    /// The largest tip opening the mesher reaches: the least of
    /// ceiling_reach_m() and cutoff_reach_m().
    double max_opening_m() const;
    /// The pocket's height less the reed's thickness and 2 x min_slab_margin_m.
    double ceiling_reach_m() const;
    /// Where the gap treated as closed would reach 0.9 of the reed's
    /// thickness even at the shape's first station: beyond, the layered gap
    /// cannot fit under the reed (cutoff_station()).
    double cutoff_reach_m() const;
    /// Which of the two limits max_opening_m() and why, for a message.
    std::string reach_limit() const;
  };

  /// The station of `shape` from which the gap under the reed is meshed
  /// (nearer the clamp it is treated as closed): the first (after the clamp)
  /// whose phi is at least `cutoff_ratio`, or nearer the clamp where the gap
  /// there, `opening_m` x phi, would not stay below 0.9 of the reed's
  /// `thickness_m` (large openings of thin reeds: the closed part shrinks).
  std::size_t cutoff_station(const SampledShape &shape, double cutoff_ratio, double opening_m, double thickness_m);

  /// The seat film's modal area: the integral of the reed's shape phi (1 at
  /// the tip) over the part of its footprint that lies on the seat, i.e. the
  /// reed [0, L] x [-W/2, W/2] less the port. A film whose pressure is p
  /// everywhere under the reed pushes on its tip-referred coordinate with
  /// p times this (docs/fluid-loading.md: the cavitation limit of the film's
  /// suction on a lifting reed). Any outline: the reed's chord at s less the
  /// ports' chords.
  double seat_film_modal_area_m2(const ValveGeometry &geometry, const std::function<double(double)> &shape);

  /// "100um", "1.21mm", "2e-6", "2e-6m" -> metres. Throws InputError naming
  /// `what` for anything else, a non-finite or a non-positive value.
  double parse_length(const std::string &text, const std::string &what);
} // namespace rectify::mesher
