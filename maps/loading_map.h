// The reed's fluid loading against its tip opening x [m], from the Stokes
// solver's two solves per opening (stokes::FluidLoading,
// docs/fluid-loading.md): what the system model's reed equation takes from
// a map set when [reed] fluid_loading = "map".
//
//   c(x)    the squeeze film's damping at a fixed pressure drop [N s/m]
//           (the Schur complement K_vv - K_Qv K_vQ / K_QQ),
//   A_m(x)  the flow the moving reed draws through the valve per unit tip
//           velocity at a fixed pressure drop [m^2] (= the modal force per
//           unit pressure drop, by reciprocity),
//   m_a(x)  the added mass of the potential flow [kg],
// all referred to the tip (the reed's shape normalised to a unit tip
// deflection), and, for the record, the damping at Q = 0 and the 2x2 map's
// asymmetry.
//
// File format (CSV, '#' comments, one '# meta:' JSON line):
//   opening_m,damping_fixed_dp_N_s_per_m,A_modal_m2,added_mass_kg,damping_N_s_per_m,asymmetry
//
// Invariants, checked on reading: at least two nodes, openings positive and
// strictly increasing, damping, area and mass finite and positive.
//
// Interpolation: monotone cubic of log c and log m_a over log x (power laws,
// c ~ x^-3 and m_a ~ x^-1 in a thin gap), of A_m over log x. Below the
// smallest solved opening x0 the film's model ends (a seat's roughness,
// cavitation under a lifting reed): c and m_a are rounded off,
// f0 (2 x0^2 / (x^2 + x0^2))^q with q minus the cubic's log-log slope at
// x0, continuous in value and slope there and smooth below (a kink stalls
// the integrator, whose reed can linger there under the squeeze film), at
// most 2^q f0 on the seat (8 c0 and 2 m_a0 for the thin-gap slopes -3 and
// -1). Extending the power law itself to the seat would glue the reed to
// it (c ~ 1e11 N s/m at 20 nm: a reed that never lifts). A_m is held.
// Above the largest opening all are held.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "maps/monotone_cubic.h"

namespace rectify::maps
{
  class LoadingMap
  {
  public:
    struct Row
    {
      double opening_m, damping_fixed_dp_N_s_per_m, A_modal_m2, added_mass_kg, damping_N_s_per_m, asymmetry;
    };
    struct Value
    {
      double damping;      ///< c at a fixed pressure drop [N s/m]
      double A_modal;      ///< [m^2]
      double added_mass;   ///< m_a [kg]
      double added_mass_slope; ///< dm_a/dx [kg/m]
    };

    /// Precondition (checked, InputError naming `name` and the row): the invariants above.
    LoadingMap(std::vector<Row> rows, std::string name, nlohmann::json metadata = nlohmann::json::object());

    static LoadingMap read(const std::filesystem::path &path);
    void              write(const std::filesystem::path &path) const;

    Value evaluate(double x) const;

    /// The seat film's modal area (the reed's shape integrated over its
    /// footprint less the port; metadata key film_modal_area_m2, written by
    /// `rectify design` since the film's suction limit): the film's largest
    /// suction force on the tip is the pressure difference times this.
    /// Empty for a table without it.
    std::optional<double> film_modal_area_m2() const { return film_area_; }

    const std::vector<Row> &rows() const { return rows_; }
    const std::string      &name() const { return name_; }

  private:
    std::vector<Row> rows_;
    std::string      name_;
    nlohmann::json   metadata_;
    std::optional<double> film_area_;
    MonotoneCubic    log_c_, a_, log_m_;
  };
} // namespace rectify::maps
