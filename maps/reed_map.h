// The reed map: the reed's stiffness, first mode and masses against its
// thickness (written by `rectify map-stiffness`, read by the system model's
// [reed] properties_map for a thickness what-if).
//
// File format (CSV, '#' lines are comments, one '# meta:' JSON line):
//
//   # rectify reed map: k_r, f1, masses and root stress vs reed thickness
//   # meta: {...}
//   thickness_m,stiffness_N_per_m,frequency_Hz,modal_mass_kg,frequency_in_fluid_Hz,
//     modal_mass_in_fluid_kg,effective_mass_eq321_kg,frequency_eq321_Hz,
//     root_stress_per_opening_Pa_per_m,root_stress_beam_per_opening_Pa_per_m,
//     root_stress_concentration,second_mode_root_stress_per_opening_Pa_per_m,n_dofs,wall_time_s
//
// The root stress columns are the FE root bending stress per unit tip opening
// (docs/stiffness.md); a map written by an earlier rectify, or by hand,
// may lack them, and then gives no stress (Properties::has_stress()).
//
// Invariants, checked on reading: columns thickness_m and stiffness_N_per_m
// (the others as needed: a map written by hand may hold only the mass it
// uses), at least one row, thicknesses strictly increasing, every value finite. Between rows, linear in thickness; outside
// them, an error (never a silent clamp).
#pragma once

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace rectify::maps
{
  class ReedMap
  {
  public:
    /// The columns `rectify map-stiffness` writes.
    static const std::vector<std::string> &columns();

    /// `rows` in `column_names` order. Precondition (checked, InputError
    /// naming `name`): the invariants above.
    ReedMap(std::vector<std::string> column_names, std::vector<std::vector<double>> rows, std::string name,
            nlohmann::json metadata = nlohmann::json::object());

    static ReedMap read(const std::filesystem::path &path);
    void           write(const std::filesystem::path &path) const;

    struct Properties
    {
      double stiffness_N_per_m, mass_kg;
      /// The root stress per unit tip opening [Pa/m], first and second mode,
      /// and the corners' concentration; NaN where the map has no such column.
      double root_stress_per_opening_Pa_per_m             = std::numeric_limits<double>::quiet_NaN();
      double second_mode_root_stress_per_opening_Pa_per_m = std::numeric_limits<double>::quiet_NaN();
      double root_stress_concentration                    = std::numeric_limits<double>::quiet_NaN();
      bool   has_stress() const { return std::isfinite(root_stress_per_opening_Pa_per_m); }
    };
    /// k_r, the mass column `mass_column` ("effective_mass_eq321_kg" or
    /// "modal_mass_in_fluid_kg") and the root stress where the map has it at
    /// `thickness_m`, linear between rows.
    /// InputError naming `where` and the map's range outside it, or if a value is not positive.
    Properties at(double thickness_m, const std::string &mass_column, const std::string &where) const;

    std::vector<double>                     column(const std::string &name) const;
    const std::vector<std::vector<double>> &rows() const { return rows_; }
    const std::string                      &name() const { return name_; }

  private:
    std::size_t                      index(const std::string &column, const std::string &where) const;
    std::vector<std::string>         columns_;
    std::vector<std::vector<double>> rows_;
    std::string                      name_;
    nlohmann::json                   metadata_;
  };
} // namespace rectify::maps
