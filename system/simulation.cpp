#include "system/simulation.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "common/case_file.h"

namespace rectify::system
{
  nlohmann::json to_json(const IntegratorStats &s)
  {
    return {{"steps", s.steps},
            {"rhs_evaluations", s.rhs_evaluations},
            {"jacobian_evaluations", s.jacobian_evaluations},
            {"rhs_evaluations_for_fd_jacobian", s.rhs_evaluations_for_fd_jacobian},
            {"nonlinear_iterations", s.nonlinear_iterations},
            {"nonlinear_convergence_failures", s.nonlinear_convergence_failures},
            {"error_test_failures", s.error_test_failures},
            {"root_function_evaluations", s.root_function_evaluations},
            {"events", s.events},
            {"reinitialisations", s.reinitialisations}};
  }

  RunOptions run_options(const SolverParameters &solver)
  {
    RunOptions r;
    r.relative_tolerance         = solver.relative_tolerance;
    r.absolute_tolerance_factor  = solver.absolute_tolerance_factor;
    r.finite_difference_jacobian = solver.jacobian == "finite-difference";
    r.samples_per_cycle          = static_cast<std::size_t>(solver.samples_per_cycle);
    r.max_steps_per_cycle        = static_cast<long>(solver.max_steps_per_cycle);
    return r;
  }

  namespace
  {
    nlohmann::json volumes_json(const std::vector<VolumeStatistics> &volumes)
    {
      nlohmann::json j = nlohmann::json::array();
      for (const auto &v : volumes)
        j.push_back(v.to_json());
      return j;
    }
  } // namespace

  nlohmann::json RunResult::to_json() const
  {
    return {{"frequency_Hz", frequency_Hz},
            {"stored_pressure_Pa", stored_pressure_Pa},
            {"mean_velocity_m_per_s", mean_velocity_m_per_s},
            {"window_start_s", start_time_s},
            {"window_end_s", end_time_s},
            {"startup_cycles", n_startup_cycles},
            {"measured_cycles", n_measured_cycles},
            {"settled", settled},
            {"metric_stderr", metric_stderr},
            {"regime", regime},
            {"wall_time_s", wall_time_s},
            {"volume_balance_rel_error", volume_balance_rel_error},
            {"max_outlet_reed_opening_m", max_outlet_reed_opening_m},
            {"max_inlet_reed_opening_m", max_inlet_reed_opening_m},
            {"min_reed_opening_m", min_reed_opening_m},
            {"min_absolute_chamber_pressure_Pa", min_absolute_chamber_pressure_Pa},
            {"piston_stroke_m", piston_stroke_m},
            {"pumped_volume_m3", pumped_volume_m3},
            {"seat_impacts", n_seat_impacts},
            {"stop_impacts", n_stop_impacts},
            {"samples_beyond_map", n_samples_beyond_map},
            {"validity", validity.to_json()},
            {"valves", {{"outlet", valves[0].to_json()}, {"inlet", valves[1].to_json()}}},
            {"volumes", volumes_json(volumes)},
            {"warnings", warnings},
            {"cvode", system::to_json(stats)}};
  }

  IntegratorOptions integrator_options(const Model &model, const RunOptions &options)
  {
    IntegratorOptions o;
    o.relative_tolerance = options.relative_tolerance;
    for (double s : model.typical_sizes())
      o.absolute_tolerances.push_back(options.absolute_tolerance_factor *
                                      options.relative_tolerance * s);
    o.finite_difference_jacobian =
      options.finite_difference_jacobian || model.needs_difference_jacobian();
    o.max_order                  = model.max_bdf_order();
    o.max_steps_between_outputs  = std::max<long>(
      500, options.max_steps_per_cycle / static_cast<long>(options.samples_per_cycle));
    return o;
  }

  namespace
  {
    const std::vector<std::string> series_columns{
      "time_s",
      "current_A",
      "piston_m",
      "fluid_mass_m",
      "actuator_m",
      "actuator_velocity_m_per_s",
      "outlet_reed_m",
      "inlet_reed_m",
      "chamber_pressure_Pa",
      "accumulator_pressure_Pa",
      "high_pressure_Pa",
      "low_pressure_Pa",
      "outlet_pressure_Pa",
      "inlet_pressure_Pa",
      "outlet_flow_m3_per_s",
      "inlet_flow_m3_per_s",
      "piston_flow_m3_per_s",
      "outlet_resistance_Pa_s_per_m3",
      "inlet_resistance_Pa_s_per_m3",
      "outlet_root_stress_Pa",
      "inlet_root_stress_Pa",
      "chamber_cavity_m3",
      "high_cavity_m3",
      "low_cavity_m3"};

    /// Decides when the cycle means of the settling metric have settled:
    /// blocks of `block` cycles; settled when the last two block-to-block
    /// changes are within the threshold, or when they shrink geometrically and
    /// the extrapolated remaining drift is (Aitken's delta-squared).
    class SettleDetector
    {
    public:
      SettleDetector(double tolerance, std::size_t block)
        : tolerance_(tolerance)
        , block_(block)
      {}

      bool add(double cycle_mean)
      {
        means_.push_back(cycle_mean);
        largest_ = std::max(largest_, std::abs(cycle_mean));
        if (means_.size() < 3 * block_ || means_.size() % block_ != 0)
          return false;
        double m[3] = {0, 0, 0};
        for (std::size_t b = 0; b < 3; ++b)
          for (std::size_t i = 0; i < block_; ++i)
            m[b] += means_[means_.size() - (3 - b) * block_ + i] / static_cast<double>(block_);
        const double threshold = tolerance_ * std::max(std::abs(m[2]), 0.05 * largest_);
        const double d1 = m[1] - m[0], d2 = m[2] - m[1];
        if (std::abs(d1) <= threshold && std::abs(d2) <= threshold)
          return true;
        const double ratio = d1 != 0.0 ? d2 / d1 : 1.0;
        return ratio > 0.0 && ratio < 0.9 && std::abs(d2 * ratio / (1.0 - ratio)) <= threshold &&
               std::abs(d2) <= 10 * threshold;
      }

    private:
      double              tolerance_;
      std::size_t         block_;
      std::vector<double> means_;
      double              largest_ = 0;
    };

    /// States compared at the ends of cycles to find the period (not the
    /// actuator position, which drifts when loaded, nor the integrals).
    constexpr std::array<std::size_t, 12> section_states{
      state::piston_x,      state::piston_v,      state::fluid_x,      state::fluid_v,
      state::actuator_v,    state::outlet_reed_x, state::outlet_reed_v, state::inlet_reed_x,
      state::inlet_reed_v,  state::chamber_p,     state::high_p,        state::low_p};

    /// "periodic", "period-k" or "non-periodic" from the Poincare sections
    /// (states at the ends of cycles), each state scaled by its range over
    /// the window's samples: period k if the last two k-cycle differences are
    /// below 1 % of the ranges. (The loaded actuator drifts slowly within the
    /// settling tolerance, so a much tighter threshold would call a periodic
    /// orbit non-periodic.)
    std::string classify(const std::vector<std::vector<double>> &sections,
                         const std::vector<double>              &scale)
    {
      const std::size_t n = sections.size();
      const auto distance = [&](std::size_t a, std::size_t b) {
        double d = 0;
        for (std::size_t i = 0; i < scale.size(); ++i)
          if (scale[i] > 0)
            d = std::max(d, std::abs(sections[a][i] - sections[b][i]) / scale[i]);
        return d;
      };
      for (std::size_t k = 1; k <= 4; ++k)
        if (n > 2 * k && distance(n - 1, n - 1 - k) < 1e-2 && distance(n - 1 - k, n - 1 - 2 * k) < 1e-2)
          return k == 1 ? "periodic" : "period-" + std::to_string(k);
      return "non-periodic";
    }

    /// Standard error of the mean of `values` from the means of 10 batches.
    double batch_standard_error(const std::vector<double> &values)
    {
      const std::size_t n_batches = std::min<std::size_t>(10, values.size());
      if (n_batches < 2)
        return 0.0;
      const std::size_t size = values.size() / n_batches;
      std::vector<double> means(n_batches, 0.0);
      for (std::size_t b = 0; b < n_batches; ++b)
        for (std::size_t i = 0; i < size; ++i)
          means[b] += values[b * size + i] / static_cast<double>(size);
      double mean = 0, var = 0;
      for (double m : means)
        mean += m / static_cast<double>(n_batches);
      for (double m : means)
        var += (m - mean) * (m - mean) / static_cast<double>(n_batches - 1);
      return std::sqrt(var / static_cast<double>(n_batches));
    }
  } // namespace

  RunResult run(Model &model, const RunOptions &options, const StartState *start)
  {
    using namespace state;
    const auto   wall_start = std::chrono::steady_clock::now();
    const double f          = model.drive().frequency_Hz();
    const double period     = 1.0 / f;
    const auto  &c          = model.constants();

    if (!options.settle)
      model.drive().check_covers(static_cast<double>(options.n_cycles) * period);
    if (options.n_cycles == 0)
      throw InputError("number of cycles must be >= 1");

    model.reset();
    std::vector<double> y0 = model.initial_state();
    if (start)
      {
        if (start->y.size() != y0.size())
          throw std::logic_error("run: the start state has " + std::to_string(start->y.size()) +
                                 " entries, the model " + std::to_string(y0.size()));
        y0 = start->y;
        for (std::size_t v = 0; v < 2; ++v)
          {
            model.set_closed(v, start->closed[v]);
            model.set_at_stop(v, start->at_stop[v]);
          }
      }
    model.sync_cavitation(y0);
    model.record_events(true);
    // Settling may run at a looser tolerance than the measured cycles.
    RunOptions startup_options = options;
    if (options.settle && options.startup_relative_tolerance > 0)
      startup_options.relative_tolerance = options.startup_relative_tolerance;
    Integrator integrator(model, 0.0, y0, integrator_options(model, startup_options));

    RunResult result;
    result.frequency_Hz = f;
    if (options.record)
      result.series.emplace(series_columns);

    const std::size_t spc = std::max<std::size_t>(options.samples_per_cycle, 4);
    SettleDetector    settle(options.settle_tolerance, 5);
    const bool        pressure_metric = model.scenario() == Scenario::no_flow;
    const double      map_max_o = model.valve_map(0).resistance().max_opening();
    const double      map_max_i = model.valve_map(1).resistance().max_opening();
    const double      map_max   = std::min(map_max_o, map_max_i);

    std::vector<double> window_start_state = y0;
    double              window_start_time  = 0.0;
    std::size_t         cycle              = 0;
    bool                measuring          = !options.settle;
    double              x_p_min = 1e300, x_p_max = -1e300;
    double              min_reed = 0.0, max_ro = 0.0, max_ri = 0.0, min_p_ch = 1e300;
    std::vector<double> row(series_columns.size());
    std::vector<double> window_means;
    std::vector<std::vector<double>> sections;
    WindowMonitor       monitor(model);
    std::vector<double> section_min(section_states.size(), 1e300),
      section_max(section_states.size(), -1e300);

    const auto cavity = [&](std::span<const double> y, std::size_t i) {
      const auto &nodes = model.cavity_nodes();
      for (std::size_t k = 0; k < nodes.size(); ++k)
        if (nodes[k] == i)
          return model.cavity_volume(k, y);
      return 0.0;
    };
    while (true)
      {
        const std::vector<double> cycle_start(integrator.state().begin(),
                                              integrator.state().end());
        for (std::size_t k = 1; k <= spc; ++k)
          {
            const double t = (static_cast<double>(cycle) + static_cast<double>(k) /
                                                             static_cast<double>(spc)) *
                             period;
            integrator.advance_to(t);
            const auto  state = integrator.state();
            const auto  y     = model.physical_state(state); // the pressures the oil has
            const Flows fl    = model.flows(y);
            const double x_o = model.opening(0, y), x_i = model.opening(1, y);
            min_reed       = std::min({min_reed, x_o, x_i});
            const auto events = model.take_events();
            if (measuring)
              {
                monitor.add(events);
                monitor.sample(state);
                x_p_min  = std::min(x_p_min, y[piston_x]);
                x_p_max  = std::max(x_p_max, y[piston_x]);
                max_ro   = std::max(max_ro, x_o);
                max_ri   = std::max(max_ri, x_i);
                min_p_ch = std::min(min_p_ch, y[chamber_p]);
                for (std::size_t i = 0; i < section_states.size(); ++i)
                  {
                    section_min[i] = std::min(section_min[i], y[section_states[i]]);
                    section_max[i] = std::max(section_max[i], y[section_states[i]]);
                  }
              }
            if (x_o > map_max_o || x_i > map_max_i)
              ++result.n_samples_beyond_map;
            if (result.series)
              {
                row = {t,
                       model.current_A(t, y),
                       y[piston_x],
                       y[fluid_x],
                       y[actuator_x],
                       y[actuator_v],
                       x_o,
                       x_i,
                       y[chamber_p],
                       y[accumulator_p],
                       y[high_p],
                       y[low_p],
                       fl.p_outlet,
                       fl.p_inlet,
                       fl.q_outlet,
                       fl.q_inlet,
                       c.A_pi * y[piston_v],
                       fl.R1,
                       fl.R2,
                       model.root_stress(0, y),
                       model.root_stress(1, y),
                       cavity(state, state::chamber_p),
                       cavity(state, state::high_p),
                       cavity(state, state::low_p)};
                result.series->add_row(row);
              }
          }
        ++cycle;
        if (options.on_cycle)
          options.on_cycle(cycle, measuring ? result.n_startup_cycles + options.n_cycles : 0);
        const auto   y          = integrator.state();
        const double cycle_mean = pressure_metric ?
                                    (y[outlet_pressure_integral] -
                                     cycle_start[outlet_pressure_integral]) / period :
                                    (y[actuator_x] - cycle_start[actuator_x]) / period;
        if (!measuring)
          {
            const bool done = settle.add(cycle_mean);
            if (done || cycle >= options.max_startup_cycles)
              {
                result.settled           = done;
                result.n_startup_cycles  = cycle;
                measuring                = true;
                if (startup_options.relative_tolerance != options.relative_tolerance)
                  {
                    const IntegratorOptions io = integrator_options(model, options);
                    integrator.set_tolerances(io.relative_tolerance, io.absolute_tolerances);
                  }
                window_start_state.assign(y.begin(), y.end());
                window_start_time = integrator.time();
              }
            continue;
          }
        window_means.push_back(cycle_mean);
        std::vector<double> section;
        for (std::size_t i : section_states)
          section.push_back(y[i]);
        sections.push_back(std::move(section));
        if (cycle - result.n_startup_cycles >= options.n_cycles)
          break;
      }

    const auto   y  = integrator.state();
    const double T  = integrator.time() - window_start_time;
    const auto   d  = [&](std::size_t i) { return y[i] - window_start_state[i]; };
    result.start_time_s          = window_start_time;
    result.end_time_s            = integrator.time();
    result.n_measured_cycles     = cycle - result.n_startup_cycles;
    result.stored_pressure_Pa    = d(outlet_pressure_integral) / T; // eq. 5.1
    result.mean_velocity_m_per_s = d(actuator_x) / T;               // eq. 5.2
    result.piston_stroke_m       = x_p_max - x_p_min;
    result.metric_stderr         = batch_standard_error(window_means);
    // Scale each state by the largest range among states of its kind
    // (positions, velocities, pressures), so that a state that barely moves
    // (the low side in a no-flow run) does not magnify its slow drift.
    constexpr std::array<int, 12> kind{0, 1, 0, 1, 1, 0, 1, 0, 1, 2, 2, 2};
    std::array<double, 3>         kind_range{0, 0, 0};
    for (std::size_t i = 0; i < kind.size(); ++i)
      kind_range[kind[i]] = std::max(kind_range[kind[i]], section_max[i] - section_min[i]);
    std::vector<double> ranges(section_states.size());
    for (std::size_t i = 0; i < ranges.size(); ++i)
      ranges[i] = kind_range[kind[i]];
    result.regime = classify(sections, ranges);
    result.pumped_volume_m3      = d(outlet_volume);
    result.max_outlet_reed_opening_m = max_ro;
    result.max_inlet_reed_opening_m  = max_ri;
    result.min_reed_opening_m        = min_reed;
    result.n_seat_impacts            = model.n_seat_impacts();
    result.n_stop_impacts            = model.n_stop_impacts();
    monitor.finish(result.valves, result.volumes, result.validity);
    result.stats                     = integrator.stats();

    // Volume balances over the run: each holds exactly for the equations, so
    // what is left is the integration error. With Delta the change from the
    // run's start (from rest: the values themselves),
    //   outlet valve:  Delta V_out = Delta(stored_h (+ stored_node, inertial line)) + A_po Delta x_act
    //   inlet valve:   Delta V_in  = -C_acc Delta p_acc - Delta stored_l + A_po Delta x_act
    //   chamber:       Delta stored_ch = A_pi Delta x_p + Delta V_in - Delta V_out
    // (a node's stored volume is the integral of its compliance, with free
    // air not linear in p: Model::stored_volume).
    const auto   dy    = [&](std::size_t i) { return y[i] - y0[i]; };
    const auto   dstored = [&](int node, std::size_t i) {
      return model.stored_volume(node, y[i]) - model.stored_volume(node, y0[i]);
    };
    const double scale = std::max({std::abs(dy(outlet_volume)), std::abs(dy(inlet_volume)),
                                   c.A_pi * std::abs(y[piston_x] - y0[piston_x]), c.A_pi * 1e-9});
    const double node_volume = model.line_stored_volume(y) - model.line_stored_volume(y0);
    const double e_out = dy(outlet_volume) - (dstored(1, high_p) + node_volume + c.A_po * dy(actuator_x));
    const double e_in  = dy(inlet_volume) -
                        (-c.C_acc * dy(accumulator_p) - dstored(2, low_p) + c.A_po * dy(actuator_x));
    const double e_ch  = dstored(0, chamber_p) - (c.A_pi * dy(piston_x) + dy(inlet_volume) - dy(outlet_volume));
    result.volume_balance_rel_error =
      std::max({std::abs(e_out), std::abs(e_in), std::abs(e_ch)}) / scale;
    result.end_state.y.assign(y.begin(), y.end());
    result.end_state.closed  = {model.closed(0), model.closed(1)};
    result.end_state.at_stop = {model.at_stop(0), model.at_stop(1)};
    model.record_events(false);

    result.min_absolute_chamber_pressure_Pa = c.p_bias + min_p_ch;
    if (result.n_samples_beyond_map > 0 && c.out_of_range == maps::OutOfRange::error)
      throw InputError("a reed opened to " + format_number(std::max(max_ro, max_ri)) +
                       " m, beyond the last node of resistance map '" +
                       model.valve_map(max_ro > map_max_o ? 0 : 1).resistance().name() + "' (" +
                       format_number(max_ro > map_max_o ? map_max_o : map_max_i) +
                       " m), and [valves] out_of_range = 'error'");
    if (!result.settled)
      result.warnings.push_back("not settled after " + std::to_string(result.n_startup_cycles) +
                                " start-up cycles");
    if (result.n_samples_beyond_map > 0)
      result.warnings.push_back(std::to_string(result.n_samples_beyond_map) +
                                " samples with a reed opening beyond the map's last node (" +
                                format_number(map_max) + " m): R held at its last value");
    if (min_reed < -1e-9)
      result.warnings.push_back("a reed passed its seat by " + format_number(-min_reed) + " m");
    result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    return result;
  }
} // namespace rectify::system
