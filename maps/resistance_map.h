// The valve resistance map R(x): flow resistance of a reed valve [Pa s/m^3]
// against its tip opening x [m], the table the system model reads and the
// Stokes solver writes.
//
// File format (CSV, readable by any tool that skips '#' lines):
//
//   # rectify resistance map
//   # meta: {"source": "...", ...}          <- one line of JSON metadata
//   opening_m,R_Pa_s_per_m3
//   0,1e+17                                  <- first node: the closed valve
//   2e-06,2.226e+11
//   ...
//
// Invariants, checked on reading: at least two nodes, openings start at 0 and
// strictly increase, resistances are finite, positive and non-increasing.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

#include "maps/monotone_cubic.h"
#include <string>
#include <vector>

namespace rectify::maps
{
  /// How R is interpolated between nodes. Both are monotone between nodes.
  enum class Interpolation
  {
    monotone_cubic, ///< log R by monotone cubic Hermite (Fritsch-Carlson, as PCHIP): the
                    ///< default; continuous slope, so an ODE solver meets no kinks
    log_linear,     ///< log R linear in x (exponential segments)
    linear,         ///< R linear in x, as the thesis (sec. 3.2.4)
    log_log         ///< log R by monotone cubic Hermite in log x: exact for a power law
                    ///< R ~ x^n (thin-gap theory's x^-3); below the first open node the
                    ///< power law of the first interval, never above the closed value.
                    ///< The map sets' interpolation (needs two open nodes).
  };

  /// What happens beyond the last node.
  enum class OutOfRange
  {
    hold, ///< R stays at the last node's value, slope 0; the model counts such samples
    error ///< the simulation stops with an error naming the opening
  };

  /// "monotone-cubic", "log-linear", "linear", "log-log"; and back.
  Interpolation parse_interpolation(const std::string &name);
  std::string   to_string(Interpolation interpolation);
  OutOfRange    parse_out_of_range(const std::string &name);

  class ResistanceMap
  {
  public:
    struct Value
    {
      double resistance;   ///< R [Pa s/m^3]
      double slope;        ///< dR/dx [Pa s/m^4]
      bool   out_of_range; ///< x beyond the last node
    };

    /// Precondition (checked, InputError naming `name`): the invariants above.
    ResistanceMap(std::vector<double> openings_m, std::vector<double> resistances,
                  std::string name, nlohmann::json metadata = nlohmann::json::object(),
                  Interpolation interpolation = Interpolation::monotone_cubic);

    static ResistanceMap read(const std::filesystem::path &path,
                              Interpolation interpolation = Interpolation::monotone_cubic);
    void                 write(const std::filesystem::path &path) const;

    /// R and dR/dx at opening x. x < 0 (a reed pressed into its seat, reached
    /// only inside a solver step before the contact event) gives the closed
    /// value R(0) with slope 0; beyond the last node the value is held (see
    /// OutOfRange) and `out_of_range` is set.
    Value evaluate(double x) const;

    double                     closed_resistance() const { return resistance_.front(); }
    double                     min_resistance() const { return resistance_.back(); }
    double                     max_opening() const { return opening_.back(); }
    const std::vector<double> &openings() const { return opening_; }
    const std::vector<double> &resistances() const { return resistance_; }
    const std::string         &name() const { return name_; }
    const nlohmann::json      &metadata() const { return metadata_; }
    Interpolation              interpolation() const { return interpolation_; }

  private:
    std::vector<double> opening_;
    std::vector<double> resistance_;
    std::vector<double> log_resistance_;
    MonotoneCubic       log_cubic_; ///< log R over x (monotone_cubic)
    MonotoneCubic       log_log_;   ///< log R over log x, open nodes (log_log)
    double              first_exponent_ = 0; ///< d log R / d log x of the first open interval
    std::string         name_;
    nlohmann::json      metadata_;
    Interpolation       interpolation_;
  };

  /// The thesis's curve (sec. 3.2.4, eq. 3.40): R = 2.34e11 exp(-0.025 x[um])
  /// sampled at log-spaced openings from 2 to 1210 um, never below the
  /// thesis's floor 4.5e8 (reached near 250 um: the fit alone falls to 0.02
  /// Pa s/m^3 at 1210 um), the closed value 1e17 at x = 0 and the floor at 5 mm.
  ResistanceMap thesis_resistance_map(std::size_t n_samples = 25);
} // namespace rectify::maps
