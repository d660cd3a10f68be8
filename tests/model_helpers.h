// The reference case's system parameters and R(x) map, for the model tests.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "common/case_file.h"
#include "maps/resistance_map.h"
#include "system/integrator.h"
#include "system/model.h"
#include "system/parameters.h"
#include "system/simulation.h"

namespace rectify::test_support
{
  inline system::SystemParameters reference()
  {
    return system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  }

  inline maps::ResistanceMap reference_map(const system::SystemParameters &p)
  {
    return maps::ResistanceMap::read(p.valves.resistance_map,
                                     maps::parse_interpolation(p.valves.interpolation));
  }
  /// A fixed-length run of `cycles` cycles with the case's tolerances.
  inline system::RunOptions run_options(const system::SystemParameters &p, std::size_t cycles)
  {
    system::RunOptions o;
    o.n_cycles                  = cycles;
    o.relative_tolerance        = p.solver.relative_tolerance;
    o.absolute_tolerance_factor = p.solver.absolute_tolerance_factor;
    return o;
  }

  /// RMS of b - a over column `name` of two recorded runs of one length,
  /// per a's RMS about its mean (its swing).
  inline double rms_difference_per_swing(const system::RunResult &a, const system::RunResult &b,
                                         const std::string &name)
  {
    const auto x = a.series->column(name), y = b.series->column(name);
    if (x.size() != y.size() || x.empty())
      throw std::logic_error("rms_difference_per_swing: '" + name + "' has " + std::to_string(x.size()) + " and " +
                             std::to_string(y.size()) + " samples");
    double mean = 0;
    for (double v : x)
      mean += v / static_cast<double>(x.size());
    double sum = 0, var = 0;
    for (std::size_t i = 0; i < x.size(); ++i)
      {
        sum += (y[i] - x[i]) * (y[i] - x[i]);
        var += (x[i] - mean) * (x[i] - mean);
      }
    return std::sqrt(sum / var);
  }

  /// CVODE options for a tight direct integration of `model`: relative
  /// tolerance `rtol`, absolute `atol_factor` times each state's typical
  /// size, difference-quotient Jacobian, no messages.
  inline system::IntegratorOptions tight_integration(const system::Model &model, double rtol, double atol_factor)
  {
    system::IntegratorOptions o;
    o.relative_tolerance = rtol;
    for (double s : model.typical_sizes())
      o.absolute_tolerances.push_back(atol_factor * s);
    o.finite_difference_jacobian = true;
    o.quiet                      = true;
    return o;
  }
} // namespace rectify::test_support
