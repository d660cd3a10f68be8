// The reference case's system parameters and R(x) map, for the model tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <vector>
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
  /// The dependences of model.rhs() on single states that `reads` (a
  /// model.rhs_reads()) leaves out, as text (empty: none): at `trials`
  /// random states, each valve open or on its seat, every state moved alone
  /// by 0.3 of its typical size, every component of f compared bit for bit.
  inline std::string rhs_reads_misses(system::Model &model, const std::vector<std::vector<std::size_t>> &reads,
                                      int trials, unsigned seed)
  {
    std::mt19937                           rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const std::size_t                      n       = model.n_states();
    const auto                             typical = model.typical_sizes();
    std::ostringstream                     misses;
    for (int trial = 0; trial < trials; ++trial)
      {
        const bool shut[2] = {trial % 2 == 1, trial % 4 >= 2};
        model.set_closed(0, shut[0]);
        model.set_closed(1, shut[1]);
        std::vector<double> y(n);
        for (std::size_t i = 0; i < n; ++i)
          y[i] = typical[i] * u(rng);
        y[system::state::outlet_reed_x] = shut[0] ? 0.0 : (1 + 200 * std::abs(u(rng))) * 1.013e-6;
        y[system::state::inlet_reed_x]  = shut[1] ? 0.0 : (1 + 200 * std::abs(u(rng))) * 1.017e-6;
        std::vector<double> f0(n), f(n);
        model.rhs(1e-3, y, f0);
        for (std::size_t j = 0; j < n; ++j)
          {
            auto yj = y;
            yj[j] += 0.3 * typical[j];
            model.rhs(1e-3, yj, f);
            for (std::size_t i = 0; i < n; ++i)
              if (f[i] != f0[i] && !(std::isnan(f[i]) && std::isnan(f0[i])) &&
                  std::find(reads[i].begin(), reads[i].end(), j) == reads[i].end())
                misses << "f[" << i << "] reads y[" << j << "] (trial " << trial << "); ";
          }
      }
    return misses.str();
  }

  /// A run of `model` from rest to t_end with the Newton matrix formed by
  /// CVODE's own routines (`cvode_linear_system`: column-by-column
  /// difference quotients or the analytic Jacobian) or by the integrator
  /// (coloured quotients), with SUNDIALS's own vector operations or the
  /// optimised ones (`library_vector_ops`): its end state and counters.
  struct DifferenceRun
  {
    std::vector<double>     state;
    system::IntegratorStats stats;
  };
  inline DifferenceRun run_linear_system(system::Model &model, const system::RunOptions &run, bool cvode_linear_system,
                                         bool finite_differences, double t_end, bool library_vector_ops = false)
  {
    model.reset();
    auto o                       = system::integrator_options(model, run);
    o.finite_difference_jacobian = finite_differences;
    o.cvode_linear_system        = cvode_linear_system;
    o.library_vector_ops         = library_vector_ops;
    o.quiet                      = true;
    o.max_steps_between_outputs  = 100000000;
    system::Integrator integrator(model, 0.0, model.initial_state(), o);
    integrator.advance_to(t_end);
    return {{integrator.state().begin(), integrator.state().end()}, integrator.stats()};
  }
} // namespace rectify::test_support
