#include "system/sweep.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <algorithm>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "common/case_file.h"
#include "common/checkpoint.h"
#include "common/io.h"
#include "common/progress.h"

namespace rectify::system
{
  SweepSeries parse_sweep_series(const std::string &name)
  {
    if (name == "dynamic")
      return {name, ValveModel::dynamic, 1.0, 1.0};
    if (name == "ideal")
      return {name, ValveModel::ideal, 1.0, 1.0};
    if (name == "reed-whatif")
      return {name, ValveModel::dynamic, 3.0, 0.5};
    throw InputError("unknown sweep series '" + name + "' (dynamic, ideal, reed-whatif)");
  }

  std::vector<double> frequency_grid(double from_Hz, double to_Hz, std::size_t n, bool log_spacing)
  {
    if (!(from_Hz > 0) || !(to_Hz >= from_Hz) || !std::isfinite(to_Hz))
      throw InputError("frequency range " + format_number(from_Hz) + " .. " +
                       format_number(to_Hz) + " Hz: need 0 < from <= to");
    if (n == 0 || (n == 1 && to_Hz != from_Hz))
      throw InputError("--n " + std::to_string(n) + ": need at least 2 frequencies for a range");
    std::vector<double> f(n);
    for (std::size_t i = 0; i < n; ++i)
      {
        const double s = n == 1 ? 0.0 : static_cast<double>(i) / static_cast<double>(n - 1);
        f[i] = log_spacing ? from_Hz * std::pow(to_Hz / from_Hz, s)
                           : from_Hz + s * (to_Hz - from_Hz);
      }
    return f;
  }

  std::string sweep_point_csv_header()
  {
    return "series,frequency_Hz,stored_pressure_Pa,mean_velocity_m_per_s,settled,metric_stderr,"
           "regime,startup_cycles,measured_cycles,wall_time_s,volume_balance_rel_error,"
           "cvode_steps,rhs_evaluations,jacobian_evaluations,events,warnings,"
           "valid,beyond_map,beyond_stop,below_cavitation_pressure,goodman_below_1,at_stop,cavitating,"
           "large_deflection,max_outlet_opening_m,max_inlet_opening_m,goodman_factor,max_root_stress_Pa,"
           "max_seat_impact_m_per_s,max_stop_impact_m_per_s,max_cavity_volume_m3,min_absolute_pressure_Pa";
  }

  void SweepPoint::set_validity(const RunResult &r)
  {
    const auto &v = r.validity;
    valid = v.valid(), beyond_map = v.beyond_map, beyond_stop = v.beyond_stop;
    below_cavitation_pressure = v.below_cavitation_pressure, goodman_below_1 = v.goodman_below_1;
    at_stop = v.at_stop, cavitating = v.cavitating, large_deflection = v.large_deflection;
    max_outlet_opening_m     = r.valves[0].max_opening_m;
    max_inlet_opening_m      = r.valves[1].max_opening_m;
    goodman_factor           = std::min(r.valves[0].goodman_factor, r.valves[1].goodman_factor);
    max_root_stress_Pa       = std::max(r.valves[0].max_root_stress_Pa, r.valves[1].max_root_stress_Pa);
    max_seat_impact_m_per_s  = std::max(r.valves[0].max_seat_impact_m_per_s, r.valves[1].max_seat_impact_m_per_s);
    max_stop_impact_m_per_s  = std::max(r.valves[0].max_stop_impact_m_per_s, r.valves[1].max_stop_impact_m_per_s);
    max_cavity_volume_m3     = 0;
    min_absolute_pressure_Pa = std::numeric_limits<double>::infinity();
    for (const auto &vol : r.volumes)
      {
        max_cavity_volume_m3     = std::max(max_cavity_volume_m3, vol.max_cavity_volume_m3);
        min_absolute_pressure_Pa = std::min(min_absolute_pressure_Pa, vol.min_absolute_pressure_Pa);
      }
  }

  std::string to_csv_row(const SweepPoint &p)
  {
    char buf[1024];
    std::snprintf(buf, sizeof(buf),
                  "%s,%.17g,%.17g,%.17g,%d,%.17g,%s,%zu,%zu,%.6g,%.6g,%ld,%ld,%ld,%ld,%zu,"
                  "%d,%d,%d,%d,%d,%d,%d,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g",
                  p.series.c_str(), p.frequency_Hz, p.stored_pressure_Pa, p.mean_velocity_m_per_s,
                  p.settled ? 1 : 0, p.metric_stderr, p.regime.c_str(), p.startup_cycles,
                  p.measured_cycles, p.wall_time_s, p.volume_balance_rel_error, p.steps,
                  p.rhs_evaluations, p.jacobian_evaluations, p.events, p.warnings, p.valid, p.beyond_map,
                  p.beyond_stop, p.below_cavitation_pressure, p.goodman_below_1, p.at_stop, p.cavitating,
                  p.large_deflection, p.max_outlet_opening_m, p.max_inlet_opening_m, p.goodman_factor,
                  p.max_root_stress_Pa, p.max_seat_impact_m_per_s, p.max_stop_impact_m_per_s,
                  p.max_cavity_volume_m3, p.min_absolute_pressure_Pa);
    return buf;
  }

  namespace
  {
    /// A hash of a file's content, so that a checkpoint made with another
    /// version of an input file is not resumed.
    std::string file_hash(const std::string &path)
    {
      std::ifstream      in(path, std::ios::binary);
      std::ostringstream content;
      content << in.rdbuf();
      return std::to_string(std::hash<std::string>{}(content.str()));
    }

    bool parse_point(const std::string &line, SweepPoint &p)
    {
      std::istringstream       in(line);
      std::vector<std::string> cell;
      std::string              c;
      while (std::getline(in, c, ','))
        cell.push_back(c);
      if (cell.size() != 32)
        return false;
      try
        {
          int settled   = 0;
          p.series      = cell[0];
          p.frequency_Hz = std::stod(cell[1]);
          p.stored_pressure_Pa = std::stod(cell[2]);
          p.mean_velocity_m_per_s = std::stod(cell[3]);
          settled                 = std::stoi(cell[4]);
          p.settled               = settled != 0;
          p.metric_stderr         = std::stod(cell[5]);
          p.regime                = cell[6];
          p.startup_cycles        = std::stoul(cell[7]);
          p.measured_cycles       = std::stoul(cell[8]);
          p.wall_time_s           = std::stod(cell[9]);
          p.volume_balance_rel_error = std::stod(cell[10]);
          p.steps                 = std::stol(cell[11]);
          p.rhs_evaluations       = std::stol(cell[12]);
          p.jacobian_evaluations  = std::stol(cell[13]);
          p.events                = std::stol(cell[14]);
          p.warnings              = std::stoul(cell[15]);
          bool *flags[] = {&p.valid,      &p.beyond_map, &p.beyond_stop,      &p.below_cavitation_pressure,
                           &p.goodman_below_1, &p.at_stop, &p.cavitating, &p.large_deflection};
          for (std::size_t i = 0; i < 8; ++i)
            *flags[i] = std::stoi(cell[16 + i]) != 0;
          double *numbers[] = {&p.max_outlet_opening_m,    &p.max_inlet_opening_m,     &p.goodman_factor,
                               &p.max_root_stress_Pa,      &p.max_seat_impact_m_per_s, &p.max_stop_impact_m_per_s,
                               &p.max_cavity_volume_m3,    &p.min_absolute_pressure_Pa};
          for (std::size_t i = 0; i < 8; ++i)
            *numbers[i] = std::stod(cell[24 + i]);
        }
      catch (const std::exception &)
        {
          return false;
        }
      return true;
    }

    /// A run the integrator could not finish: its numbers NaN, why in the
    /// regime column (commas and line breaks replaced: one CSV cell).
    SweepPoint failed_point(const std::string &series, double frequency, const std::string &why)
    {
      std::string text = "failed: " + why;
      for (char &ch : text)
        if (ch == ',' || ch == '\n' || ch == '\r')
          ch = ';';
      const double nan = std::numeric_limits<double>::quiet_NaN();
      SweepPoint p{series, frequency, nan, nan, false, nan, text, 0, 0, 0.0, nan, 0, 0, 0, 0, 1};
      p.max_outlet_opening_m = p.max_inlet_opening_m = p.goodman_factor = p.max_root_stress_Pa = nan;
      p.max_seat_impact_m_per_s = p.max_stop_impact_m_per_s = p.max_cavity_volume_m3 = p.min_absolute_pressure_Pa = nan;
      return p;
    }

    std::string key(const std::string &series, double f)
    {
      char buf[64];
      std::snprintf(buf, sizeof(buf), "%.17g", f);
      return series + "@" + buf;
    }

    std::string state_csv_header() { return "key,outlet_contact,inlet_contact,state"; }

    /// One end state as a CSV row: the point's key, the valves' discrete
    /// states and the continuous state, separated by spaces (exact round trip).
    std::string to_state_row(const std::string &point_key, const StartState &s)
    {
      // each valve: 1 on its seat, 2 held at its stop, 0 free
      const auto  mode = [&](std::size_t v) { return s.closed[v] ? "1" : s.at_stop[v] ? "2" : "0"; };
      std::string row  = point_key + "," + mode(0) + "," + mode(1) + ",";
      char        buf[32];
      for (std::size_t i = 0; i < s.y.size(); ++i)
        {
          std::snprintf(buf, sizeof(buf), "%s%.17g", i ? " " : "", s.y[i]);
          row += buf;
        }
      return row;
    }

    bool parse_state(const std::string &row, std::string &point_key, StartState &s)
    {
      std::istringstream       in(row);
      std::vector<std::string> cell;
      std::string              c;
      while (std::getline(in, c, ','))
        cell.push_back(c);
      const auto mode = [](const std::string &c) { return c == "0" || c == "1" || c == "2"; };
      if (cell.size() != 4 || !mode(cell[1]) || !mode(cell[2]))
        return false;
      point_key = cell[0];
      for (std::size_t v = 0; v < 2; ++v)
        {
          s.closed[v]  = cell[1 + v] == "1";
          s.at_stop[v] = cell[1 + v] == "2";
        }
      s.y.clear();
      std::istringstream values(cell[3]);
      std::string        v;
      try
        {
          while (values >> v)
            s.y.push_back(std::stod(v));
        }
      catch (const std::exception &)
        {
          return false;
        }
      return !s.y.empty();
    }

    /// The start of frequency f from the chain's previous points (one or
    /// two, ascending): the last end state, with the slow states (load
    /// velocity, high, low and accumulator pressure) extrapolated along the
    /// secant through the last two. Not the velocity of the no-flow case's
    /// 1e12 kg output: it would keep any speed given to it. The fast states (piston, reeds, chamber)
    /// are left as they were: extrapolating them could put a reed through its seat.
    StartState predicted_start(const std::vector<std::pair<double, StartState>> &previous, double f,
                               Scenario scenario)
    {
      StartState start = previous.back().second;
      if (previous.size() < 2)
        return start;
      const auto &[fa, a] = previous[previous.size() - 2];
      const auto &[fb, b] = previous.back();
      if (a.y.size() != b.y.size() || fb == fa)
        return start;
      const double s = (f - fb) / (fb - fa);
      for (std::size_t i : {std::size_t(state::actuator_v), std::size_t(state::high_p),
                            std::size_t(state::low_p), std::size_t(state::accumulator_p)})
        if (i != state::actuator_v || scenario == Scenario::loaded) // no-flow: the output held
          start.y[i] = b.y[i] + s * (b.y[i] - a.y[i]);
      return start;
    }

    /// A run of frequencies of one series, each started from its lower neighbour's end.
    struct Chain
    {
      SweepSeries         series;
      std::vector<double> frequencies; ///< ascending
      double              cost = 0;    ///< estimated simulated time [s]
    };

    /// The series' frequencies, ascending, cut into `n_chains` runs of about
    /// equal cost (0: every frequency its own chain, from rest). A run's cost
    /// goes with its simulated time: (measured cycles + start-up) / f, where
    /// a start from rest needs about 15 + f / 4 cycles (the load's speed-up,
    /// measured on the reference case) and a continued one about 20.
    std::vector<Chain> make_chains(const SweepSeries &series, std::vector<double> f,
                                   std::size_t n_chains, std::size_t n_cycles)
    {
      std::sort(f.begin(), f.end());
      f.erase(std::unique(f.begin(), f.end()), f.end());
      const double m = static_cast<double>(n_cycles);
      const auto cold = [&](double x) { return (m + 15.0 + 0.25 * x) / x; };
      const auto warm = [&](double x) { return (m + 20.0) / x; };
      std::vector<Chain> chains;
      if (n_chains == 0)
        {
          for (double x : f)
            chains.push_back({series, {x}, cold(x)});
          return chains;
        }
      double total = 0;
      for (std::size_t i = 0; i < f.size(); ++i)
        total += i == 0 ? cold(f[i]) : warm(f[i]);
      const double target = total / static_cast<double>(std::min(n_chains, f.size()));
      for (double x : f)
        {
          if (chains.empty() || (chains.back().cost >= target && chains.size() < n_chains))
            chains.push_back({series, {x}, cold(x)});
          else
            {
              chains.back().frequencies.push_back(x);
              chains.back().cost += warm(x);
            }
        }
      return chains;
    }
  } // namespace

  SweepOptions default_sweep_options(const SystemParameters &p, Scenario scenario, std::vector<double> frequencies_Hz,
                                     std::size_t n_cycles)
  {
    SweepOptions s;
    s.scenario             = scenario;
    s.current_pp_A         = p.drive.current_pp_A;
    s.current_bias_A       = p.drive.current_bias_A;
    s.frequencies_Hz       = std::move(frequencies_Hz);
    s.run                  = run_options(p.solver);
    s.run.settle           = true;
    s.run.n_cycles         = n_cycles;
    s.run.settle_tolerance = 2e-3;
    s.run.max_startup_cycles = 1000;
    // A sweep records no time series: a few samples a cycle serve the
    // diagnostics (reed openings, chamber pressure); the solution itself
    // does not depend on them (CVODE interpolates to each sample).
    s.run.samples_per_cycle = 16;
    return s;
  }

  namespace
  {
    /// Everything that changes a result: a resumed sweep takes the points a
    /// previous one with this fingerprint finished.
    nlohmann::json sweep_fingerprint(const SystemParameters &parameters, const SweepOptions &options)
    {
      nlohmann::json fingerprint = {{"scenario", to_string(options.scenario)},
                                    {"current_pp_A", options.current_pp_A},
                                    {"current_bias_A", options.current_bias_A},
                                    {"settle", options.run.settle},
                                    {"n_cycles", options.run.n_cycles},
                                    {"settle_tolerance", options.run.settle_tolerance},
                                    {"max_startup_cycles", options.run.max_startup_cycles},
                                    {"relative_tolerance", options.run.relative_tolerance},
                                    {"startup_relative_tolerance", options.run.startup_relative_tolerance},
                                    {"absolute_tolerance_factor", options.run.absolute_tolerance_factor},
                                    {"finite_difference_jacobian", options.run.finite_difference_jacobian},
                                    {"chains", options.chains},
                                    {"parameters", parameters.to_json()},
                                    {"resistance_map_hash", file_hash(parameters.valves.resistance_map)}};
      for (std::size_t v = 0; v < 2; ++v) // a map set's manifest holds its tables' hashes
        if (!parameters.valves.map_set[v].empty())
          fingerprint[v == 0 ? "outlet_map_set_hash" : "inlet_map_set_hash"] =
            file_hash(std::filesystem::path(parameters.valves.map_set[v]) / "manifest.json");
      return fingerprint;
    }

    /// One sweep: its checkpoint (the finished points and, with chains,
    /// their end states), its chains of frequencies shared out over threads.
    /// Continuation: each series' frequencies, ascending, in chains; within a
    /// chain every frequency starts from the state its lower neighbour ended
    /// in, its slow states (load velocity, high, low and accumulator
    /// pressures) moved along the secant through the last two (a predictor).
    /// Each frequency's end state is checkpointed beside its result, so a
    /// resumed sweep continues exactly as an uninterrupted one would.
    /// (Without chains every run starts from rest: no states are kept.)
    class SweepRun
    {
    public:
      SweepRun(const SystemParameters &parameters, const SweepOptions &options, const std::filesystem::path &out_dir)
        : parameters(parameters)
        , options(options)
        , fingerprint(sweep_fingerprint(parameters, options))
        , checkpoint(out_dir, "sweep-partial", fingerprint, sweep_point_csv_header())
      {
        for (const auto &row : checkpoint.finished_rows())
          {
            SweepPoint p;
            if (parse_point(row, p))
              done[key(p.series, p.frequency_Hz)] = p;
          }
        if (options.chains > 0)
          {
            states.emplace(out_dir, "sweep-states", fingerprint, state_csv_header());
            for (const auto &row : states->finished_rows())
              {
                std::string key_text;
                StartState  st;
                if (parse_state(row, key_text, st))
                  end_states[key_text] = std::move(st);
              }
          }
        for (const auto &s : options.series)
          for (auto &c : make_chains(s, options.frequencies_Hz, options.chains, options.run.n_cycles))
            {
              bool all_done = true;
              for (double f : c.frequencies)
                all_done = all_done && done.count(key(s.name, f));
              if (!all_done)
                chains.push_back(std::move(c));
            }
        std::stable_sort(chains.begin(), chains.end(), [](const Chain &a, const Chain &b) { return a.cost > b.cost; });
      }

      SweepResult run()
      {
        SweepResult result;
        result.n_resumed          = done.size();
        const std::size_t n_total = options.series.size() * options.frequencies_Hz.size();
        progress.emplace("sweep", n_total, done.size(), options.quiet);
        const unsigned n_threads = std::max(
          1u, std::min<unsigned>(options.jobs ? options.jobs : std::thread::hardware_concurrency(),
                                 static_cast<unsigned>(chains.size())));
        std::vector<std::thread> threads;
        for (unsigned t = 0; t < n_threads && !chains.empty(); ++t)
          threads.emplace_back([this] { worker(); });
        for (auto &t : threads)
          t.join();
        if (failure)
          std::rethrow_exception(failure);
        for (const auto &s : options.series)
          for (double f : options.frequencies_Hz)
            result.points.push_back(done.at(key(s.name, f)));
        return result;
      }

    private:
      void                      record(const SweepPoint &pt, const std::string &what);
      std::optional<StartState> run_point(const SweepSeries &series, double frequency, const StartState *start);
      void                      run_chain(const Chain &chain);
      void                      worker();

      const SystemParameters           &parameters;
      const SweepOptions               &options;
      const nlohmann::json              fingerprint;
      Checkpoint                        checkpoint;
      std::map<std::string, SweepPoint> done;
      std::optional<Checkpoint>         states;
      std::map<std::string, StartState> end_states; ///< of the runs finished before a resume
      std::vector<Chain>                chains;
      std::optional<Progress>           progress;
      std::mutex                        mutex;
      std::atomic<std::size_t>          next{0};
      std::exception_ptr                failure;
    };

    /// A finished point: checkpointed, kept, reported.
    void SweepRun::record(const SweepPoint &pt, const std::string &what)
    {
      checkpoint.append(to_csv_row(pt));
      {
        std::lock_guard<std::mutex> lock(mutex);
        done[key(pt.series, pt.frequency_Hz)] = pt;
      }
      progress->step(what);
    }

    /// One run, checkpointed; returns its end state (a chain's next start),
    /// none if the integrator failed: then the point is recorded as failed
    /// (regime "failed: <why>", its numbers NaN) and the sweep goes on.
    std::optional<StartState> SweepRun::run_point(const SweepSeries &series, double frequency,
                                                  const StartState *start)
    {
    SystemParameters p = parameters;
    p.reed.stiffness_N_per_m *= series.stiffness_factor;
    p.reed.effective_mass_kg *= series.mass_factor;
    Model model(p, load_valve_maps(p), series.valves, options.scenario,
                Drive::sine(frequency, options.current_pp_A, options.current_bias_A));
    RunResult r;
    try
      {
        r = system::run(model, options.run, start);
      }
    catch (const InputError &)
      {
        throw; // the case's fault: every point would fail
      }
    catch (const std::runtime_error &e)
      {
        const SweepPoint pt = failed_point(series.name, frequency, e.what());
        record(pt, series.name + " " + format_number(frequency) + " Hz: " + pt.regime);
        return std::nullopt;
      }
    SweepPoint pt{series.name,
                  frequency,
                  r.stored_pressure_Pa,
                  r.mean_velocity_m_per_s,
                  r.settled,
                  r.metric_stderr,
                  r.regime,
                  r.n_startup_cycles,
                  r.n_measured_cycles,
                  r.wall_time_s,
                  r.volume_balance_rel_error,
                  r.stats.steps,
                  r.stats.rhs_evaluations,
                  r.stats.jacobian_evaluations,
                  r.stats.events,
                  r.warnings.size()};
    pt.set_validity(r);
    // The state first: a point whose row is written always has its state.
    if (states)
      states->append(to_state_row(key(series.name, frequency), r.end_state));
    char what[160];
    std::snprintf(what, sizeof(what), "%s %.4g Hz: %s %.4g, %zu+%zu cycles, %.2f s",
                  pt.series.c_str(), pt.frequency_Hz,
                  options.scenario == Scenario::no_flow ? "p_str [Pa]" : "v [m/s]",
                  options.scenario == Scenario::no_flow ? pt.stored_pressure_Pa :
                                                          pt.mean_velocity_m_per_s,
                  pt.startup_cycles, pt.measured_cycles, pt.wall_time_s);
    record(pt, what);
    return std::move(r.end_state);
    }

    /// A chain's frequencies in turn, each from its neighbour's end state
    /// (or from rest: the first, one after a failure, one finished before a
    /// resume without its state).
    void SweepRun::run_chain(const Chain &chain)
    {
      // Two previous points of the chain (frequency, end state) for the predictor.
      std::vector<std::pair<double, StartState>> previous;
      for (double f : chain.frequencies)
        {
          std::optional<StartState> finished; // before a resume
          {
            std::lock_guard<std::mutex> lock(mutex);
            if (failure)
              return;
            if (done.count(key(chain.series.name, f)))
              {
                const auto it = end_states.find(key(chain.series.name, f));
                if (it == end_states.end())
                  {
                    previous.clear(); // no state: the next one starts from rest
                    continue;
                  }
                finished = it->second;
              }
          }
          std::optional<StartState> end;
          if (finished)
            end = std::move(*finished);
          else if (previous.empty())
            end = run_point(chain.series, f, nullptr);
          else
            {
              const StartState start = predicted_start(previous, f, options.scenario);
              end                    = run_point(chain.series, f, &start);
            }
          if (!end)
            { // failed: the next frequency starts from rest
              previous.clear();
              continue;
            }
          previous.emplace_back(f, std::move(*end));
          if (previous.size() > 2)
            previous.erase(previous.begin());
        }
    }

    void SweepRun::worker()
    {
      try
        {
          while (true)
            {
              const std::size_t i = next++;
              if (i >= chains.size())
                return;
              run_chain(chains[i]);
              std::lock_guard<std::mutex> lock(mutex);
              if (failure)
                return;
            }
        }
      catch (...)
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (!failure)
            failure = std::current_exception();
        }
    }
  } // namespace

  SweepResult run_sweep(const SystemParameters &parameters, const SweepOptions &options,
                        const std::filesystem::path &out_dir)
  {
    const auto wall_start = std::chrono::steady_clock::now();
    if (options.series.empty() || options.frequencies_Hz.empty())
      throw InputError("sweep: nothing to run (no series or no frequencies)");
    for (std::size_t i = 0; i < options.series.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (options.series[i].name == options.series[j].name)
          throw InputError("sweep: series '" + options.series[i].name + "' given twice");
    SweepResult result = SweepRun(parameters, options, out_dir).run();
    result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    return result;
  }
} // namespace rectify::system
