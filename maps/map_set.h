// A map set: everything the system model needs to know about one reed valve,
// computed once by `rectify design` (or written from the thesis's values by
// `rectify map-thesis`), in one folder:
//
//   manifest.json   provenance: the values (and a hash) of every case table
//                   the maps depend on, code version, mesh and solver
//                   settings, per opening its DoFs, iterations, mass balance
//                   and wall time, the interpolation error achieved; the
//                   reed's stiffness and masses; a hash of each table file
//   resistance.csv  R(x) (maps/resistance_map.h), with its interpolation
//   area.csv        A_eff(x) (maps/area_map.h)
//   loading.csv     the reed's fluid loading: squeeze-film damping, the flow
//                   it displaces, added mass (maps/loading_map.h); optional
//
// beside which `rectify design` writes the solved points, plots, the reed's
// shape and modes and a report. The manifest is written last: a folder
// without one is not a map set (an interrupted run), and a table whose hash
// differs from the manifest's is refused.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "common/fluid.h"
#include "common/reed_material.h"
#include "common/valve_geometry.h"
#include "maps/area_map.h"
#include "maps/loading_map.h"
#include "maps/resistance_map.h"

namespace rectify::maps
{
  inline constexpr int map_set_format_version = 1;

  /// The reed as the stiffness solver found it (first bending mode,
  /// normalised to a unit mean tip deflection).
  struct ReedProperties
  {
    double stiffness_N_per_m        = 0; ///< k_r: load / mean tip deflection
    double modal_mass_kg            = 0; ///< first mode in vacuum
    double modal_mass_in_fluid_kg   = 0; ///< with eq. 3.20's added mass spread like the plate's
    double effective_mass_eq321_kg  = 0; ///< the thesis's 2.75 (m_plate + m_added)
    double frequency_Hz             = 0; ///< first mode in vacuum
    double frequency_in_fluid_Hz    = 0;
    double plate_mass_kg            = 0;
    double added_mass_kg            = 0; ///< eq. 3.20
    /// The clamp's bending stress per unit mean tip deflection [Pa/m]
    /// (stiffness_solver/elasticity.h): FE width-mean, beam theory's, the
    /// corners' concentration, the second bending mode's. 0: a map set
    /// written before they existed.
    double root_stress_per_opening_Pa_per_m             = 0;
    double root_stress_beam_per_opening_Pa_per_m        = 0;
    double root_stress_concentration                    = 0;
    double second_mode_root_stress_per_opening_Pa_per_m = 0;
    bool   has_stress() const { return root_stress_per_opening_Pa_per_m > 0; }
    nlohmann::json to_json() const;
    static ReedProperties from_json(const nlohmann::json &j, const std::string &where);
  };

  /// The case tables a map set depends on for the system model's use, as
  /// {"geometry": {...}, "fluid": {...}, "reed_material": {...}}: the values
  /// that must match between the case and the map set (the fluid: density
  /// and viscosity only).
  nlohmann::json physical_tables(const ValveGeometry &geometry, const FluidParameters &fluid,
                                 const ReedMaterial &material);

  /// {"values": table, "hash": content_hash(table.dump())} for each table.
  nlohmann::json hashed_tables(const nlohmann::json &tables);

  class MapSet
  {
  public:
    MapSet(ResistanceMap resistance, AreaMap area, double seated_area_m2,
           std::optional<ReedProperties> reed, nlohmann::json manifest);

    /// Reads DIR/manifest.json and the tables it names; InputError naming the
    /// file and field for a missing or malformed manifest, a table missing,
    /// malformed, non-finite or not matching the manifest's hash.
    static MapSet read(const std::filesystem::path &dir);
    /// Writes the tables, then manifest.json (with their hashes), each atomically.
    void write(const std::filesystem::path &dir) const;

    /// Throws InputError naming the table and key that differ if the map set
    /// depends on case tables (`physical_tables` of the case, `case_name` for
    /// the message) other than the case's. A map set without such provenance
    /// (the thesis's) passes.
    void check_matches(const nlohmann::json &case_tables, const std::string &case_name) const;

    const ResistanceMap                 &resistance() const { return resistance_; }
    const AreaMap                       &area() const { return area_; }
    double                               seated_area_m2() const { return seated_area_m2_; }
    const std::optional<ReedProperties> &reed() const { return reed_; }
    const std::optional<LoadingMap>     &loading() const { return loading_; }
    void set_loading(LoadingMap loading) { loading_ = std::move(loading); }
    const nlohmann::json                &manifest() const { return manifest_; }
    const std::string                   &name() const { return name_; }

  private:
    ResistanceMap                 resistance_;
    AreaMap                       area_;
    double                        seated_area_m2_;
    std::optional<ReedProperties> reed_;
    std::optional<LoadingMap>     loading_;
    nlohmann::json                manifest_;
    std::string                   name_; ///< the folder, for messages
  };

  /// A valve described by an R(x) map alone, as the thesis's (eq. 3.40:
  /// thesis_resistance_map or the shipped cases/thesis-resistance.csv):
  /// A_eff = `pressure_area_m2` (the thesis's A_r) at every opening and
  /// seated, no reed (the case's k_r and m_r apply), no provenance.
  MapSet map_set_from_resistance(ResistanceMap resistance, double pressure_area_m2);
} // namespace rectify::maps
