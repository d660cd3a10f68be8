// The reed's effective pressure area A_eff(x) = F_z / (p_in - p_out) [m^2]
// against its tip opening x [m]: the fluid force on an open reed is
// A_eff(x) times the valve's pressure drop. The Stokes solver computes it;
// the system model reads it from a map set.
//
// File format (CSV, '#' lines are comments, one '# meta:' JSON line):
//
//   # rectify area map
//   # meta: {...}
//   opening_m,A_eff_m2
//   2e-06,1.61e-05
//   ...
//
// Invariants, checked on reading: at least one node, openings positive and
// strictly increasing, areas finite and positive.
//
// Interpolation: monotone cubic (PCHIP) of A over log x. Below the first
// node the first value is held: for a reed shape scaled by its tip opening,
// thin-gap (Reynolds) theory's pressure field does not depend on the
// opening, so A_eff tends to a constant as x -> 0 (the Stokes solutions
// agree to 4 digits from 2 to 50 um, docs/stokes.md). Beyond the last node
// the last value is held, like R(x).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "maps/monotone_cubic.h"

namespace rectify::maps
{
  class AreaMap
  {
  public:
    struct Value
    {
      double area;  ///< A_eff [m^2]
      double slope; ///< dA_eff/dx [m]
    };

    /// Precondition (checked, InputError naming `name`): the invariants above.
    AreaMap(std::vector<double> openings_m, std::vector<double> areas_m2, std::string name,
            nlohmann::json metadata = nlohmann::json::object());
    /// A_eff = `area_m2` at every opening (the thesis's constant A_r).
    static AreaMap constant(double area_m2, std::string name);

    static AreaMap read(const std::filesystem::path &path);
    void           write(const std::filesystem::path &path) const;

    Value evaluate(double x) const;

    const std::vector<double> &openings() const { return opening_; }
    const std::vector<double> &areas() const { return area_; }
    const std::string         &name() const { return name_; }
    const nlohmann::json      &metadata() const { return metadata_; }

  private:
    std::vector<double> opening_, area_;
    std::string         name_;
    nlohmann::json      metadata_;
    MonotoneCubic       cubic_; ///< A over log x (two or more nodes)
  };
} // namespace rectify::maps
