#include "diagnosis/runs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "diagnosis/fit.h"
#include "diagnosis/search.h"
#include "diagnosis/words.h"

namespace rectify::diagnosis
{
  SimulationOptions RunCase::simulation(double relative_tolerance) const
  {
    SimulationOptions so;
    so.relative_tolerance = relative_tolerance;
    so.start              = start;
    so.lead_cycles        = lead_cycles;
    so.band_Hz            = band_Hz;
    so.recorded           = recorded;
    so.drive              = drive;
    return so;
  }


  double band_reed_frequency_Hz(const system::SystemParameters &p, system::Scenario scenario,
                                const DiagnoseOptions &options)
  {
    return options.harmonics_auto && scenario == system::Scenario::loaded ? p.reed.natural_frequency_Hz() : 0.0;
  }

  BaselineSecondMode baseline_second_mode(const system::SystemParameters &p, system::Scenario scenario,
                                          const std::string &choice)
  {
    const double f1 = p.reed.natural_frequency_Hz(), fc = p.reed.second_mode_frequency_Hz;
    const std::string f1_text = format_number(std::round(f1 * 10) / 10);
    if (choice == "case")
      return {fc, fc > 0 ? "the case's [reed] second_mode_frequency_Hz" : "none: the case gives none"};
    if (choice != "auto")
      {
        char        *end = nullptr;
        const double f   = std::strtod(choice.c_str(), &end);
        if (choice.empty() || *end != '\0' || !std::isfinite(f) || f <= f1)
          throw InputError("--reed-second-mode '" + choice + "': give auto, case or a frequency [Hz] above the "
                           "reed's first mode (" + f1_text + " Hz)");
        return {f, "given (--reed-second-mode)"};
      }
    if (fc > 0)
      return {fc, "the case's [reed] second_mode_frequency_Hz"};
    // Every run, no-flow too: a real reed's second mode shows in no-flow
    // records as well, and a one-mode baseline leaves it as a residual
    // far above the noise.
    constexpr double uniform_cantilever = (4.6941 / 1.8751) * (4.6941 / 1.8751);
    return {uniform_cantilever * f1, "a uniform cantilever's, 6.267 x the first mode (" + f1_text +
                                       " Hz): a real reed has one, and it shows in the valve's opening, " +
                                       (scenario == system::Scenario::loaded ? "most of all in a loaded run" :
                                                                               "even in a no-flow run") +
                                       " (the case gives none; --reed-second-mode case keeps one mode)"};
  }

  double compared_harmonics(double harmonics, double frequency_Hz, double reed_frequency_Hz)
  {
    if (!(harmonics > 0) || !(reed_frequency_Hz > 0) || !(frequency_Hz > 0))
      return harmonics;
    return std::min(harmonics, std::max(1.0, std::floor(0.5 * reed_frequency_Hz / frequency_Hz)));
  }

  RunCase make_run_case(MeasuredRun run, system::Scenario scenario, double frequency_Hz,
                        double training_fraction, bool repair_outliers, double harmonics,
                        double reed_frequency_Hz)
  {
    RunCase rc;
    if (repair_outliers)
      rc.outliers = run.repair_outliers(6.0, frequency_Hz);
    const double f = frequency_Hz > 0 ? frequency_Hz : run.drive_frequency_Hz();
    for (const auto &c : signal_columns())
      if (run.has(c))
        rc.white_sd[c] = white_noise_sd(run.signal(c));
    rc.recorded = recorded_state(run, f); // before the band limit: the laser's own noise decides "open"
    const double h = compared_harmonics(harmonics, f, reed_frequency_Hz);
    if (h > 0 && uniformly_sampled(run.time_s))
      {
        rc.band_why     = h < harmonics ? RunCase::BandWhy::below_reed : RunCase::BandWhy::as_asked;
        rc.reed_Hz      = reed_frequency_Hz;
        rc.harmonics    = h;
        const double dt = run.duration_s() / static_cast<double>(run.time_s.size() - 1);
        rc.band_Hz      = (h + 0.5) * f;
        if (rc.band_Hz * dt < 0.5)
          {
            rc.band_fraction = rc.band_Hz * dt * 2.0;
            std::vector<double> t(run.time_s.size());
            for (std::size_t i = 0; i < t.size(); ++i)
              t[i] = run.time_s[i] - run.time_s.front();
            for (const auto &c : signal_columns())
              if (run.has(c))
                run.signals[c] = band_limit(t, run.signal(c), rc.band_Hz);
          }
        else
          {
            rc.band_Hz     = 0;
            rc.harmonics   = 0;
            rc.band_why    = RunCase::BandWhy::nyquist;
          }
      }
    for (const auto &c : signal_columns())
      if (run.has(c))
        rc.cyclic_sd[c] = cycle_scatter(run.time_s, run.signal(c), f);
    rc.setup.scenario     = scenario;
    rc.setup.frequency_Hz = f;
    rc.swings             = signal_scales(run);
    rc.scales             = rc.swings;
    rc.drive_noise_sd     = white_noise_sd(run.signal(run.drive_column()));
    rc.n_train = std::max<std::size_t>(
      10, static_cast<std::size_t>(std::floor(training_fraction * static_cast<double>(run.time_s.size()))));
    rc.run   = std::move(run);
    rc.drive = std::make_shared<const system::Drive>(measured_drive(rc.run, f));
    return rc;
  }

  double screening_cycles_per_run(const std::vector<RunCase> &runs, double cap)
  {
    if (!(cap > 0))
      return 0;
    std::vector<double> have; // training cycles after the settling, per run
    double              total = 0;
    for (const auto &rc : runs)
      {
        const double dt = rc.run.duration_s() / static_cast<double>(rc.run.time_s.size() - 1);
        const double n  = static_cast<double>(rc.n_train > rc.n_skip ? rc.n_train - rc.n_skip : 0);
        have.push_back(n * dt * rc.setup.frequency_Hz);
        total += have.back();
      }
    if (total <= cap)
      return 0;
    // the level h with sum over runs of min(have, h) = cap
    std::sort(have.begin(), have.end());
    double left = cap;
    for (std::size_t i = 0; i < have.size(); ++i)
      {
        const double share = left / static_cast<double>(have.size() - i);
        if (have[i] >= share)
          return std::max(3.0, share);
        left -= have[i];
      }
    return 0; // not reached: total > cap
  }

  void calibrate_noise(const system::SystemParameters &base, const system::ValveMaps &map,
                       std::vector<RunCase> &runs, double rtol, unsigned threads)
  {
    // The model's response to the drive's noise, from three realisations
    // of it, their median per signal: a model that rings (an inertial line)
    // answers now and then with a jump (a closing shifted by a step), which
    // one realisation would take for the rule.
    constexpr int realisations = 3;
    std::vector<std::vector<Signals>> shaken(runs.size(), std::vector<Signals>(realisations + 1));
    parallel_for(runs.size() * (realisations + 1), threads, [&](std::size_t job) {
      const std::size_t i = job / (realisations + 1), k = job % (realisations + 1);
      const auto &rc = runs[i];
      auto        so = rc.simulation(rtol);
      if (k > 0 && !(rc.drive_noise_sd > 0))
        return;
      if (k > 0)
        {
          so.drive_noise_sd = rc.drive_noise_sd;
          so.seed           = 12344 + k;
        }
      shaken[i][k] = simulate_run(base, map, rc.run, rc.setup, so);
    });
    for (std::size_t i = 0; i < runs.size(); ++i)
      {
        auto       &rc    = runs[i];
        const auto &clean = shaken[i][0];
        for (const auto &[name, values] : clean)
          {
            std::vector<double> d2;
            for (int k = 1; k <= realisations; ++k)
              if (shaken[i][static_cast<std::size_t>(k)].count(name))
                {
                  const auto &other = shaken[i][static_cast<std::size_t>(k)].at(name);
                  double      sum   = 0;
                  for (std::size_t j = 0; j < values.size(); ++j)
                    sum += std::pow(other[j] - values[j], 2) / static_cast<double>(values.size());
                  d2.push_back(sum);
                }
            std::sort(d2.begin(), d2.end());
            const double response = d2.empty() ? 0.0 : d2[d2.size() / 2];
            // the data's own noise inside the band: white noise's share of
            // it, or (coloured noise, flutter) the scatter from cycle to cycle
            const double white    = (rc.white_sd.count(name) ? rc.white_sd.at(name) : white_noise_sd(rc.run.signal(name))) *
                                 std::sqrt(rc.band_fraction);
            const double measured = std::max(white, rc.cyclic_sd.count(name) ? rc.cyclic_sd.at(name) : 0.0);
            rc.scales[name] = std::max(std::sqrt(measured * measured + response), 1e-3 * rc.swings.at(name));
          }
      }
  }

  void choose_start(const system::SystemParameters &base, const system::ValveMaps &map,
                    std::vector<RunCase> &runs, const DiagnoseOptions &options, unsigned threads)
  {
    const auto lead = [&](StartState s) {
      return s == StartState::rest || from_record(s) ? 0.0 : s == StartState::steady ? 3.0 : options.lead_cycles;
    };
    // in this order of preference: a later one must fit 5 % better. The
    // high side at the first cycle's mean pressure only in no-flow runs,
    // where the high side is closed (in a loaded run it follows the load
    // through the cycle).
    std::vector<StartState> tried{StartState::rest, StartState::record, StartState::record_mean,
                                  StartState::steady, StartState::periodic};
    if (std::any_of(runs.begin(), runs.end(),
                    [](const RunCase &rc) { return rc.setup.scenario != system::Scenario::no_flow; }))
      tried.erase(std::find(tried.begin(), tried.end(), StartState::record_mean));
    if (options.start != "auto")
      tried = {start_state_from_string(options.start)};
    // each run with each start: the residual over its first two cycles (in
    // units of each signal's swing), the case's baseline
    std::vector<std::vector<double>> score(runs.size(), std::vector<double>(tried.size(), 0.0));
    if (tried.size() > 1)
      parallel_for(runs.size() * tried.size(), threads, [&](std::size_t job) {
        const std::size_t r = job / tried.size(), k = job % tried.size();
        const RunCase    &rc = runs[r];
        auto              so = rc.simulation(options.relative_tolerance);
        so.start             = tried[k];
        so.lead_cycles       = lead(tried[k]);
        const auto &t        = rc.run.time_s;
        const double dt      = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
        so.n_samples = std::min(t.size(), static_cast<std::size_t>(2.0 / (rc.setup.frequency_Hz * dt)) + 1);
        try
          {
            const auto model = simulate_run(base, map, rc.run, rc.setup, so);
            const auto r2    = squared_residual(rc.run, model, rc.swings, 0, so.n_samples);
            score[r][k]      = std::sqrt(r2.sum / static_cast<double>(std::max<std::size_t>(r2.n, 1)));
          }
        catch (const std::exception &)
          {
            score[r][k] = 1e300;
          }
      });
    for (std::size_t r = 0; r < runs.size(); ++r)
      {
        auto       &rc   = runs[r];
        std::size_t best = 0;
        rc.start_scores  = nlohmann::json::object();
        // the first tried (rest) unless another fits clearly better: a run
        // that starts at rest under a drive that starts at zero is also a
        // steady start, within the drive's noise. A run-in (steady,
        // periodic) must beat the recorded state by 20 %: it assumes the
        // history before the record, which the case's baseline judges here
        // and a slow effect (a soft seal, free air, charging the high side
        // over tens of cycles) would change, where the recorded state
        // assumes nothing.
        for (std::size_t k = 0; k < tried.size(); ++k)
          {
            if (tried.size() > 1)
              rc.start_scores[to_string(tried[k])] = score[r][k];
            const bool   run_in = tried[k] == StartState::steady || tried[k] == StartState::periodic;
            const double margin = run_in && from_record(tried[best]) ? 0.8 : 0.95;
            if (score[r][k] < margin * score[r][best])
              best = k;
          }
        rc.start       = tried[best];
        rc.lead_cycles = lead(rc.start);
        const double settling =
          options.settling_cycles >= 0 ? options.settling_cycles : rc.start == StartState::rest ? 0.0 : 1.0;
        const auto  &t  = rc.run.time_s;
        const double dt = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
        rc.n_skip = std::min(rc.n_train / 2, static_cast<std::size_t>(std::llround(settling / (rc.setup.frequency_Hz * dt))));
        rc.start_memory.clear();
        using Why   = RunCase::Settling::Why;
        rc.settling = {options.settling_cycles >= 0   ? Why::given :
                       rc.start == StartState::rest ? Why::rest_exact :
                                                      Why::one_cycle};
      }
  }

  std::size_t settled_from(const std::vector<double> &d, double tolerance, std::size_t min_cycles,
                           std::size_t max_cycles)
  {
    std::size_t c = d.size();
    while (c > 0 && d[c - 1] <= tolerance)
      --c;
    return std::clamp(c, min_cycles, std::max(min_cycles, max_cycles));
  }

  bool runs_meet(const std::vector<double> &d, double tolerance)
  {
    if (d.empty())
      return false;
    // runs that have come at least half-way together meet later (a slow
    // mode); the window is then the most settled_from allows
    return d.back() <= tolerance || d.back() <= 0.5 * *std::max_element(d.begin(), d.end());
  }

  void settle(const system::SystemParameters &base, const system::ValveMaps &map, std::vector<RunCase> &runs,
              const DiagnoseOptions &options, unsigned threads)
  {
    using Why = RunCase::Settling::Why;
    if (options.settling_cycles >= 0)
      return;
    std::vector<std::size_t> todo;
    for (std::size_t r = 0; r < runs.size(); ++r)
      if (runs[r].start != StartState::rest)
        todo.push_back(r);
    // each run from its start and from the other
    std::vector<std::array<Signals, 2>> model(runs.size());
    std::vector<std::array<bool, 2>>    ok(runs.size(), {false, false});
    parallel_for(2 * todo.size(), threads, [&](std::size_t job) {
      const std::size_t r = todo[job / 2], k = job % 2;
      const RunCase    &rc = runs[r];
      auto              so = rc.simulation(options.relative_tolerance);
      so.n_samples         = rc.n_train;
      if (k == 1)
        {
          so.start       = rc.start == StartState::periodic ? StartState::record : StartState::periodic;
          so.lead_cycles = so.start == StartState::periodic ? options.lead_cycles : 0.0;
        }
      try
        {
          model[r][k] = simulate_run(base, map, rc.run, rc.setup, so);
          ok[r][k]    = true;
        }
      catch (const std::exception &)
        {
        }
    });
    for (std::size_t r : todo)
      {
        auto        &rc = runs[r];
        const auto  &t  = rc.run.time_s;
        const double dt = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
        const double m  = 1.0 / (rc.setup.frequency_Hz * dt); // samples per cycle
        const auto   cycles = static_cast<std::size_t>(std::floor(static_cast<double>(rc.n_train) / m));
        // one cycle unless measured (as choose_start left it; set again for
        // a later round, which may not choose the start again)
        rc.n_skip = std::min(rc.n_train / 2, static_cast<std::size_t>(std::llround(m)));
        if (!ok[r][0] || !ok[r][1] || cycles < 2)
          {
            rc.settling = {cycles < 2 ? Why::few_cycles : Why::run_failed};
            continue;
          }
        rc.settling = {Why::settled, rc.start,
                       rc.start == StartState::periodic ? StartState::record : StartState::periodic};
        rc.start_memory.clear();
        for (std::size_t c = 0; c < cycles; ++c)
          {
            const auto from = static_cast<std::size_t>(std::llround(static_cast<double>(c) * m));
            const auto to   = static_cast<std::size_t>(std::llround(static_cast<double>(c + 1) * m));
            double     sum  = 0;
            std::size_t n   = 0;
            for (const auto &[name, a] : model[r][0])
              {
                const auto it = model[r][1].find(name);
                if (it == model[r][1].end())
                  continue;
                const double scale = rc.scales.at(name);
                for (std::size_t i = from; i < std::min({to, a.size(), it->second.size()}); ++i, ++n)
                  sum += std::pow((a[i] - it->second[i]) / scale, 2);
              }
            rc.start_memory.push_back(std::sqrt(sum / static_cast<double>(std::max<std::size_t>(n, 1))));
          }
        auto &s = rc.settling;
        if (!runs_meet(rc.start_memory, options.settling_tolerance))
          {
            // two orbits (an outlet valve that opens every cycle from one
            // start and stays shut from the other): no memory to measure
            s.why     = Why::orbits_apart;
            s.last    = rc.start_memory.back();
            s.largest = *std::max_element(rc.start_memory.begin(), rc.start_memory.end());
          }
        else
          {
            const std::size_t c = settled_from(rc.start_memory, options.settling_tolerance, 1, cycles / 2);
            rc.n_skip = std::min(rc.n_train / 2, static_cast<std::size_t>(std::llround(static_cast<double>(c) * m)));
            s.cycles  = c;
            if (c == cycles / 2 && rc.start_memory[c] > options.settling_tolerance)
              {
                s.why   = Why::meets_later;
                s.apart = rc.start_memory[c];
              }
            else
              {
                s.tolerance = options.settling_tolerance;
                s.apart     = rc.start_memory.front();
              }
          }
        if (options.progress)
          options.progress("settling of " + rc.run.source + ": " + settling_words(rc));
      }
  }
  std::vector<RunCase> read_run_cases(const std::vector<std::string> &paths, system::Scenario scenario,
                                      double frequency_Hz, const DiagnoseOptions &options, double reed_frequency_Hz,
                                      const std::function<void(const std::string &)> &notice)
  {
    std::vector<RunCase> runs;
    const auto           num = [](const char *format, double v) {
      std::string text(static_cast<std::size_t>(std::snprintf(nullptr, 0, format, v)), '\0');
      std::snprintf(text.data(), text.size() + 1, format, v);
      return text;
    };
    for (const auto &path : paths)
      {
        auto run = MeasuredRun::read(path, frequency_Hz);
        for (const auto &c : run.ignored_columns)
          notice("notice: '" + path + "': column '" + c + "' ignored (not a quantity the model predicts)");
        runs.push_back(make_run_case(std::move(run), scenario, frequency_Hz, options.training_fraction,
                                     options.repair_outliers, options.harmonics, reed_frequency_Hz));
        for (const auto &x : runs.back().outliers)
          notice("notice: '" + path + "': row " + std::to_string(x.row) + ", " + x.column + ": an isolated spike of " +
                 num("%.3g", x.size) + " (" + num("%.0f", x.noise_units) + " noise sd) replaced by its neighbours' mean");
        const auto &rc = runs.back();
        if (scenario == system::Scenario::no_flow && rc.run.has("actuator_position_m"))
          {
            const auto  &x     = rc.run.signal("actuator_position_m");
            const double range = *std::max_element(x.begin(), x.end()) - *std::min_element(x.begin(), x.end());
            if (range > 1e-4)
              notice("warning: '" + path + "': the actuator moves " + num("%.3g", 1e3 * range) +
                     " mm, but the scenario is no-flow (--scenario loaded?)");
          }
      }
    return runs;
  }
} // namespace rectify::diagnosis
