#include "system/simulation.h"

#include <optional>

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

  namespace
  {
    /// One run: from its start state through the start-up cycles (until
    /// the cycle means settle) and the measured cycles, sample by sample,
    /// to the run's metrics, volume balance and warnings. run() is
    /// RunLoop(...).run().
    class RunLoop
    {
    public:
      RunLoop(Model &model, const RunOptions &options, const StartState *start);
      RunResult run();

    private:
      std::vector<double> start_state(const StartState *start);
      void                sample(double t);
      /// Ends a cycle; true when the run has measured all its cycles.
      bool                end_cycle(std::span<const double> cycle_start);
      void                measure();
      void                close_volume_balance();
      void                check_map_and_warn();

      using clock = std::chrono::steady_clock;
      const clock::time_point wall_start_ = clock::now();
      Model                  &model_;
      const RunOptions       &options_;
      const ModelConstants   &c_;
      const double            period_;
      RunOptions              startup_options_;
      std::vector<double>     y0_;
      std::optional<Integrator> integrator_;
      RunResult               result_;

      std::size_t         spc_;
      SettleDetector      settle_;
      bool                pressure_metric_;
      double              map_max_o_, map_max_i_;
      std::vector<double> window_start_state_;
      double              window_start_time_ = 0.0;
      std::size_t         cycle_             = 0;
      bool                measuring_;
      double              x_p_min_ = 1e300, x_p_max_ = -1e300;
      double              min_reed_ = 0.0, max_ro_ = 0.0, max_ri_ = 0.0, min_p_ch_ = 1e300;
      std::vector<double> row_;
      std::vector<double> window_means_;
      std::vector<std::vector<double>> sections_;
      WindowMonitor       monitor_;
      std::vector<double> section_min_, section_max_;
    };

    RunLoop::RunLoop(Model &model, const RunOptions &options, const StartState *start)
      : model_(model)
      , options_(options)
      , c_(model.constants())
      , period_(1.0 / model.drive().frequency_Hz())
      , startup_options_(options)
      , spc_(std::max<std::size_t>(options.samples_per_cycle, 4))
      , settle_(options.settle_tolerance, 5)
      , pressure_metric_(model.scenario() == Scenario::no_flow)
      , map_max_o_(model.valve_map(0).resistance().max_opening())
      , map_max_i_(model.valve_map(1).resistance().max_opening())
      , measuring_(!options.settle)
      , row_(series_columns.size())
      , monitor_(model)
      , section_min_(section_states.size(), 1e300)
      , section_max_(section_states.size(), -1e300)
    {
      if (!options.settle)
        model.drive().check_covers(static_cast<double>(options.n_cycles) * period_);
      if (options.n_cycles == 0)
        throw InputError("number of cycles must be >= 1");
      y0_ = start_state(start);
      model.sync_cavitation(y0_);
      model.record_events(true);
      // Settling may run at a looser tolerance than the measured cycles.
      if (options.settle && options.startup_relative_tolerance > 0)
        startup_options_.relative_tolerance = options.startup_relative_tolerance;
      integrator_.emplace(model, 0.0, y0_, integrator_options(model, startup_options_));
      result_.frequency_Hz = model.drive().frequency_Hz();
      if (options.record)
        result_.series.emplace(series_columns);
      window_start_state_ = y0_;
    }

    std::vector<double> RunLoop::start_state(const StartState *start)
    {
      model_.reset();
      std::vector<double> y0 = model_.initial_state();
      if (!start)
        return y0;
      if (start->y.size() != y0.size())
        throw std::logic_error("run: the start state has " + std::to_string(start->y.size()) +
                               " entries, the model " + std::to_string(y0.size()));
      for (std::size_t v = 0; v < 2; ++v)
        {
          model_.set_closed(v, start->closed[v]);
          model_.set_at_stop(v, start->at_stop[v]);
        }
      return start->y;
    }

    RunResult RunLoop::run()
    {
      while (true)
        {
          const std::vector<double> cycle_start(integrator_->state().begin(), integrator_->state().end());
          for (std::size_t k = 1; k <= spc_; ++k)
            sample((static_cast<double>(cycle_) + static_cast<double>(k) / static_cast<double>(spc_)) * period_);
          if (end_cycle(cycle_start))
            break;
        }
      measure();
      close_volume_balance();
      check_map_and_warn();
      result_.wall_time_s = std::chrono::duration<double>(clock::now() - wall_start_).count();
      return std::move(result_);
    }

    void RunLoop::sample(double t)
    {
      using namespace state;
      integrator_->advance_to(t);
      const auto   state = integrator_->state();
      const auto   y     = model_.physical_state(state); // the pressures the oil has
      const Flows  fl    = model_.flows(y);
      const double x_o = model_.opening(0, y), x_i = model_.opening(1, y);
      min_reed_         = std::min({min_reed_, x_o, x_i});
      const auto events = model_.take_events();
      if (measuring_)
        {
          monitor_.add(events);
          monitor_.sample(state);
          x_p_min_  = std::min(x_p_min_, y[piston_x]);
          x_p_max_  = std::max(x_p_max_, y[piston_x]);
          max_ro_   = std::max(max_ro_, x_o);
          max_ri_   = std::max(max_ri_, x_i);
          min_p_ch_ = std::min(min_p_ch_, y[chamber_p]);
          for (std::size_t i = 0; i < section_states.size(); ++i)
            {
              section_min_[i] = std::min(section_min_[i], y[section_states[i]]);
              section_max_[i] = std::max(section_max_[i], y[section_states[i]]);
            }
        }
      if (x_o > map_max_o_ || x_i > map_max_i_)
        ++result_.n_samples_beyond_map;
      if (!result_.series)
        return;
      const auto cavity = [&](std::size_t i) {
        const auto &nodes = model_.cavity_nodes();
        for (std::size_t k = 0; k < nodes.size(); ++k)
          if (nodes[k] == i)
            return model_.cavity_volume(k, state);
        return 0.0;
      };
      row_ = {t,           model_.current_A(t, y), y[piston_x],    y[fluid_x],    y[actuator_x],
              y[actuator_v], x_o,                  x_i,            y[chamber_p],  y[accumulator_p],
              y[high_p],   y[low_p],               fl.p_outlet,    fl.p_inlet,    fl.q_outlet,
              fl.q_inlet,  c_.A_pi * y[piston_v],  fl.R1,          fl.R2,         model_.root_stress(0, y),
              model_.root_stress(1, y), cavity(chamber_p), cavity(high_p), cavity(low_p)};
      result_.series->add_row(row_);
    }

    bool RunLoop::end_cycle(std::span<const double> cycle_start)
    {
      using namespace state;
      ++cycle_;
      if (options_.on_cycle)
        options_.on_cycle(cycle_, measuring_ ? result_.n_startup_cycles + options_.n_cycles : 0);
      const auto   y          = integrator_->state();
      const double cycle_mean = pressure_metric_ ?
                                  (y[outlet_pressure_integral] - cycle_start[outlet_pressure_integral]) / period_ :
                                  (y[actuator_x] - cycle_start[actuator_x]) / period_;
      if (!measuring_)
        {
          const bool done = settle_.add(cycle_mean);
          if (done || cycle_ >= options_.max_startup_cycles)
            {
              result_.settled          = done;
              result_.n_startup_cycles = cycle_;
              measuring_               = true;
              if (startup_options_.relative_tolerance != options_.relative_tolerance)
                {
                  const IntegratorOptions io = integrator_options(model_, options_);
                  integrator_->set_tolerances(io.relative_tolerance, io.absolute_tolerances);
                }
              window_start_state_.assign(y.begin(), y.end());
              window_start_time_ = integrator_->time();
            }
          return false;
        }
      window_means_.push_back(cycle_mean);
      std::vector<double> section;
      for (std::size_t i : section_states)
        section.push_back(y[i]);
      sections_.push_back(std::move(section));
      return cycle_ - result_.n_startup_cycles >= options_.n_cycles;
    }

    void RunLoop::measure()
    {
      using namespace state;
      const auto   y = integrator_->state();
      const double T = integrator_->time() - window_start_time_;
      const auto   d = [&](std::size_t i) { return y[i] - window_start_state_[i]; };
      result_.start_time_s          = window_start_time_;
      result_.end_time_s            = integrator_->time();
      result_.n_measured_cycles     = cycle_ - result_.n_startup_cycles;
      result_.stored_pressure_Pa    = d(outlet_pressure_integral) / T; // eq. 5.1
      result_.mean_velocity_m_per_s = d(actuator_x) / T;               // eq. 5.2
      result_.piston_stroke_m       = x_p_max_ - x_p_min_;
      result_.metric_stderr         = batch_standard_error(window_means_);
      // Scale each state by the largest range among states of its kind
      // (positions, velocities, pressures), so that a state that barely moves
      // (the low side in a no-flow run) does not magnify its slow drift.
      constexpr std::array<int, 12> kind{0, 1, 0, 1, 1, 0, 1, 0, 1, 2, 2, 2};
      std::array<double, 3>         kind_range{0, 0, 0};
      for (std::size_t i = 0; i < kind.size(); ++i)
        kind_range[kind[i]] = std::max(kind_range[kind[i]], section_max_[i] - section_min_[i]);
      std::vector<double> ranges(section_states.size());
      for (std::size_t i = 0; i < ranges.size(); ++i)
        ranges[i] = kind_range[kind[i]];
      result_.regime                    = classify(sections_, ranges);
      result_.pumped_volume_m3          = d(outlet_volume);
      result_.max_outlet_reed_opening_m = max_ro_;
      result_.max_inlet_reed_opening_m  = max_ri_;
      result_.min_reed_opening_m        = min_reed_;
      result_.n_seat_impacts            = model_.n_seat_impacts();
      result_.n_stop_impacts            = model_.n_stop_impacts();
      monitor_.finish(result_.valves, result_.volumes, result_.validity);
      result_.stats = integrator_->stats();
      result_.min_absolute_chamber_pressure_Pa = c_.p_bias + min_p_ch_;
    }

    void RunLoop::close_volume_balance()
    {
      // Volume balances over the run: each holds exactly for the equations, so
      // what is left is the integration error. With Delta the change from the
      // run's start (from rest: the values themselves),
      //   outlet valve:  Delta V_out = Delta(stored_h (+ stored_node, inertial line)) + A_po Delta x_act
      //   inlet valve:   Delta V_in  = -C_acc Delta p_acc - Delta stored_l + A_po Delta x_act
      //   chamber:       Delta stored_ch = A_pi Delta x_p + Delta V_in - Delta V_out
      // (a node's stored volume is the integral of its compliance, with free
      // air not linear in p: Model::stored_volume).
      using namespace state;
      const auto   y       = integrator_->state();
      const auto  &y0      = y0_;
      const auto   dy      = [&](std::size_t i) { return y[i] - y0[i]; };
      const auto   dstored = [&](std::size_t node, std::size_t i) {
        return model_.stored_volume(node, y[i]) - model_.stored_volume(node, y0[i]);
      };
      const double scale = std::max({std::abs(dy(outlet_volume)), std::abs(dy(inlet_volume)),
                                     c_.A_pi * std::abs(y[piston_x] - y0[piston_x]), c_.A_pi * 1e-9});
      const double node_volume = model_.component_stored_volume(y) - model_.component_stored_volume(y0);
      const double e_out = dy(outlet_volume) - (dstored(1, high_p) + node_volume + c_.A_po * dy(actuator_x));
      const double e_in =
        dy(inlet_volume) - (-c_.C_acc * dy(accumulator_p) - dstored(2, low_p) + c_.A_po * dy(actuator_x));
      const double e_ch = dstored(0, chamber_p) - (c_.A_pi * dy(piston_x) + dy(inlet_volume) - dy(outlet_volume));
      result_.volume_balance_rel_error = std::max({std::abs(e_out), std::abs(e_in), std::abs(e_ch)}) / scale;
      result_.end_state.y.assign(y.begin(), y.end());
      result_.end_state.closed  = {model_.closed(0), model_.closed(1)};
      result_.end_state.at_stop = {model_.at_stop(0), model_.at_stop(1)};
      model_.record_events(false);
    }

    void RunLoop::check_map_and_warn()
    {
      const double map_max = std::min(map_max_o_, map_max_i_);
      if (result_.n_samples_beyond_map > 0 && c_.out_of_range == maps::OutOfRange::error)
        throw InputError("a reed opened to " + format_number(std::max(max_ro_, max_ri_)) +
                         " m, beyond the last node of resistance map '" +
                         model_.valve_map(max_ro_ > map_max_o_ ? 0 : 1).resistance().name() + "' (" +
                         format_number(max_ro_ > map_max_o_ ? map_max_o_ : map_max_i_) +
                         " m), and [valves] out_of_range = 'error'");
      if (!result_.settled)
        result_.warnings.push_back("not settled after " + std::to_string(result_.n_startup_cycles) +
                                   " start-up cycles");
      if (result_.n_samples_beyond_map > 0)
        result_.warnings.push_back(std::to_string(result_.n_samples_beyond_map) +
                                   " samples with a reed opening beyond the map's last node (" +
                                   format_number(map_max) + " m): R held at its last value");
      if (min_reed_ < -1e-9)
        result_.warnings.push_back("a reed passed its seat by " + format_number(-min_reed_) + " m");
    }
  } // namespace

  RunResult run(Model &model, const RunOptions &options, const StartState *start)
  {
    return RunLoop(model, options, start).run();
  }
} // namespace rectify::system
