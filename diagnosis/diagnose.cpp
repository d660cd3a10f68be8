#include "diagnosis/diagnose.h"

#include <nlopt.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "common/case_file.h"

namespace rectify::diagnosis
{
  namespace
  {
    using Clock = std::chrono::steady_clock;

    double seconds_since(Clock::time_point start)
    {
      return std::chrono::duration<double>(Clock::now() - start).count();
    }

    /// fn(i) for i in [0, n) on up to `threads` threads; rethrows the first
    /// exception. The runs of one evaluation are independent simulations.
    template <typename F>
    void parallel_for(std::size_t n, unsigned threads, const F &fn)
    {
      threads = static_cast<unsigned>(std::min<std::size_t>(std::max(1u, threads), n));
      if (threads <= 1)
        {
          for (std::size_t i = 0; i < n; ++i)
            fn(i);
          return;
        }
      std::atomic<std::size_t> next{0};
      std::exception_ptr       error;
      std::mutex               mutex;
      std::vector<std::thread> pool;
      for (unsigned t = 0; t < threads; ++t)
        pool.emplace_back([&] {
          for (std::size_t i; (i = next++) < n;)
            try
              {
                fn(i);
              }
            catch (...)
              {
                std::lock_guard lock(mutex);
                if (!error)
                  error = std::current_exception();
              }
        });
      for (auto &t : pool)
        t.join();
      if (error)
        std::rethrow_exception(error);
    }

    /// Parameters at a point u in [0, 1]^(k): the effect's parameters, then the gain.
    struct Evaluator
    {
      const system::SystemParameters &base;
      const system::ValveMaps        &map;
      const std::vector<RunCase>     &runs;
      const Effect                   *effect; // null: none
      const DiagnoseOptions          &options;
      unsigned                        run_threads = 1; ///< runs simulated at once per evaluation
      /// The model the effect extends, simulated (for starts from the data).
      const std::vector<Signals>     *reference = nullptr;
      /// > 0: fit only this many pumping cycles from the start of each run.
      double                          horizon_cycles = 0;

      std::size_t samples(const RunCase &rc) const
      {
        if (!(horizon_cycles > 0))
          return rc.n_train;
        const auto  &t  = rc.run.time_s;
        const double dt = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
        const auto   n  = static_cast<std::size_t>(horizon_cycles / (rc.setup.frequency_Hz * dt)) + 1;
        return std::min(rc.n_train, n);
      }

      std::size_t dimension() const { return (effect ? effect->parameters().size() : 0) + 1; }

      std::vector<double> values(const std::vector<double> &u) const
      {
        std::vector<double> v;
        if (effect)
          for (std::size_t i = 0; i < effect->parameters().size(); ++i)
            v.push_back(effect->parameters()[i].from_unit(u[i]));
        return v;
      }
      double gain(const std::vector<double> &u) const
      {
        return 1.0 + options.gain_range * (2.0 * u.back() - 1.0);
      }
      system::SystemParameters parameters(const std::vector<double> &u) const
      {
        system::SystemParameters p = base;
        if (effect)
          effect->apply(values(u), p);
        p.transducer.piezomagnetic_coefficient_m_per_A *= gain(u);
        return p;
      }
      /// Sum of squared normalised residuals over the training samples.
      SquaredResidual training(const std::vector<double> &u) const
      {
        const auto                   p = parameters(u);
        std::vector<SquaredResidual> per_run(runs.size());
        parallel_for(runs.size(), run_threads, [&](std::size_t i) {
          const auto       &rc = runs[i];
          SimulationOptions so;
          so.relative_tolerance = options.relative_tolerance;
          so.n_samples          = samples(rc);
          const auto model      = simulate_run(p, map, rc.run, rc.setup, so);
          per_run[i]            = squared_residual(rc.run, model, rc.scales, 0, so.n_samples);
        });
        SquaredResidual total;
        for (const auto &r : per_run)
          {
            total.sum += r.sum;
            total.n += r.n;
          }
        return total;
      }
    };

    struct Objective
    {
      const Evaluator *evaluator;
      int              evaluations = 0;
      int              failures    = 0;
      std::size_t      n           = 0;
      double           best        = 1e300;
      std::vector<double> best_u;
    };

    double objective(unsigned n, const double *x, double *, void *data)
    {
      auto *o = static_cast<Objective *>(data);
      std::vector<double> u(x, x + n);
      ++o->evaluations;
      double value;
      try
        {
          const auto r = o->evaluator->training(u);
          o->n         = r.n;
          value        = r.sum / static_cast<double>(std::max<std::size_t>(r.n, 1));
          if (!std::isfinite(value))
            throw std::runtime_error("non-finite residual");
        }
      catch (const std::exception &)
        {
          ++o->failures;
          value = 1e6; // the model failed to integrate here: far worse than any fit
        }
      if (value < o->best)
        {
          o->best   = value;
          o->best_u = u;
        }
      return value;
    }

    std::vector<Signals> simulate_all(const system::SystemParameters &p,
                                      const system::ValveMaps &map,
                                      const std::vector<RunCase> &runs, double rtol, unsigned threads = 1)
    {
      std::vector<Signals> out(runs.size());
      parallel_for(runs.size(), threads, [&](std::size_t i) {
        SimulationOptions so;
        so.relative_tolerance = rtol;
        out[i]                = simulate_run(p, map, runs[i].run, runs[i].setup, so);
      });
      return out;
    }

    /// RMS of normalised residuals over samples [from, to) of every run
    /// (to = 0: the end), pooled.
    double pooled_rms(const std::vector<RunCase> &runs, const std::vector<Signals> &model,
                      bool heldout)
    {
      SquaredResidual total;
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          const auto &rc = runs[r];
          const auto  s  = heldout ? squared_residual(rc.run, model[r], rc.scales, rc.n_train,
                                                      rc.run.time_s.size()) :
                                     squared_residual(rc.run, model[r], rc.scales, 0, rc.n_train);
          total.sum += s.sum;
          total.n += s.n;
        }
      return std::sqrt(total.sum / static_cast<double>(std::max<std::size_t>(total.n, 1)));
    }

    /// A start for an effect whose first parameter sets a lightly damped
    /// ringing (EffectParameter::ringing_Hz), or nothing. The residual's
    /// dependence on such a parameter is a comb of basins: over the
    /// training part of a 100 Hz run a basin is about +-1 % of L wide, over
    /// its first 3 cycles +-5 % (the ringing's phase error grows with time).
    /// So: (1) the frequency of the largest peak in the residual of the
    /// outlet (or chamber) pressure of each run, between 2.5 f and 0.4 of
    /// the sampling rate, gives through ringing_Hz a value per run, their
    /// median a centre; (2) a scan of +-25 % about it in 2 % steps over the
    /// first 3 cycles of each run; (3) a scan of +-2 % in 0.5 % steps about
    /// the best over the first 6. Returns the best point of (3), with the
    /// force gain at 1, or an empty vector when the residual shows no
    /// ringing in the parameter's range; counts its (short) runs of the
    /// model into runs_of_the_model.
    std::vector<double> ringing_start(const Evaluator &ev, int &runs_of_the_model)
    {
      const EffectParameter &par = ev.effect->parameters()[0];
      std::vector<double>    centres;
      for (std::size_t r = 0; r < ev.runs.size(); ++r)
        {
          const auto       &rc = ev.runs[r];
          const std::string name = rc.run.has("outlet_pressure_Pa") ? "outlet_pressure_Pa" :
                                   rc.run.has("chamber_pressure_Pa") ? "chamber_pressure_Pa" : "";
          if (name.empty() || !ev.reference || !(*ev.reference)[r].count(name))
            continue;
          const auto &data = rc.run.signal(name);
          const auto &model = (*ev.reference)[r].at(name);
          std::vector<double> t(rc.n_train), residual(rc.n_train);
          for (std::size_t i = 0; i < rc.n_train; ++i)
            {
              t[i]        = rc.run.time_s[i];
              residual[i] = data[i] - model[i];
            }
          const double fs = static_cast<double>(rc.n_train - 1) / (t.back() - t.front());
          // the ringing the parameter's bounds allow (decreasing in the value)
          const double f_high = std::min(0.4 * fs, par.ringing_Hz(par.lower, ev.base));
          const double f_low  = std::max(2.5 * rc.setup.frequency_Hz, par.ringing_Hz(par.upper, ev.base));
          if (!(f_low < f_high))
            continue;
          const double f_peak = dominant_frequency(t, residual, f_low, f_high);
          if (!(f_peak > 0))
            continue;
          double a = 0, b = 1; // ringing_Hz(from_unit(u)) = f_peak, by bisection
          for (int i = 0; i < 60; ++i)
            {
              const double mid = 0.5 * (a + b);
              (par.ringing_Hz(par.from_unit(mid), ev.base) > f_peak ? a : b) = mid;
            }
          centres.push_back(par.from_unit(0.5 * (a + b)));
        }
      if (centres.empty())
        return {};
      std::sort(centres.begin(), centres.end());
      double best_value = centres[centres.size() / 2];

      const unsigned dim  = static_cast<unsigned>(ev.dimension());
      const auto     scan = [&](double horizon, double ratio, int half_width) {
        Evaluator short_ev      = ev;
        short_ev.horizon_cycles = horizon;
        Objective o{&short_ev, 0, 0, 0, 1e300, {}};
        for (int j = -half_width; j <= half_width; ++j)
          {
            const double v = best_value * std::pow(ratio, j);
            if (v < par.lower || v > par.upper)
              continue;
            std::vector<double> u(dim, 0.5);
            u[0] = par.to_unit(v);
            objective(dim, u.data(), nullptr, &o);
          }
        if (!o.best_u.empty())
          best_value = par.from_unit(o.best_u[0]);
        return o.evaluations;
      };
      runs_of_the_model += scan(3.0, 1.02, 12);
      runs_of_the_model += scan(6.0, 1.005, 4);
      std::vector<double> u(dim, 0.5);
      u[0] = par.to_unit(best_value);
      return u;
    }

    /// Fits ev's candidate: from a coarse grid over the effect's first
    /// parameter (gain 1), or, when `from_point` is given (a point in
    /// [0, 1]^k), locally from there with small first steps.
    CandidateResult fit(const Evaluator &ev, std::vector<Signals> &predictions,
                        const std::vector<double> *from_point = nullptr)
    {
      const auto      start = Clock::now();
      CandidateResult c;
      c.effect = ev.effect ? ev.effect->name() : "none";
      Objective o{&ev, 0, 0, 0, 1e300, {}};
      const unsigned dim = static_cast<unsigned>(ev.dimension());
      std::vector<double> u(dim, 0.5);
      struct Start
      {
        double              value; ///< the objective there
        std::vector<double> u;
        double              step;  ///< BOBYQA's first step from there
      };
      std::vector<Start> grid;
      const int grid_points = ev.effect && ev.effect->parameters()[0].grid_points > 0 ?
                                ev.effect->parameters()[0].grid_points :
                                ev.options.grid_points;
      // a ringing's basins are narrow: first steps of 0.25 % of the value
      const EffectParameter *ringing =
        ev.effect && ev.effect->parameters()[0].ringing_Hz ? &ev.effect->parameters()[0] : nullptr;
      const auto fine_step = [&](const std::vector<double> &at) {
        const double v = ringing->from_unit(at[0]);
        return std::abs(ringing->to_unit(std::min(ringing->upper, v * 1.0025)) - at[0]) + 1e-6;
      };
      const auto add_start = [&](const std::vector<double> &at, double step) {
        grid.push_back({objective(dim, at.data(), nullptr, &o), at, step});
      };
      int short_runs = 0; // runs of the model over part of the record (ringing_start)
      if (from_point)
        add_start(*from_point, ringing ? fine_step(*from_point) : 0.02);
      else if (ev.effect)
        {
          for (int g = 0; g < grid_points; ++g)
            {
              u[0] = (g + 0.5) / grid_points;
              add_start(u, 0.5 / grid_points);
            }
          if (ringing)
            if (const auto r = ringing_start(ev, short_runs); !r.empty())
              add_start(r, fine_step(r));
        }
      else
        add_start(u, 0.5 / grid_points);
      std::sort(grid.begin(), grid.end(), [](const Start &a, const Start &b) { return a.value < b.value; });
      // BOBYQA from the best grid points (the residual of a valve that opens
      // by a small pressure difference can have several basins); each
      // restarted (smaller first step) from its best point while a restart
      // still gains 1 %: the objective is slightly rough at the integrator's
      // tolerance, which can stop a trust region early in a curved valley
      // (effect vs force gain).
      nlopt_result status = NLOPT_SUCCESS;
      const std::size_t starts = std::min<std::size_t>(grid.size(), ev.effect ? 2 : 1);
      for (std::size_t start_i = 0; start_i < starts; ++start_i)
        {
          std::vector<double> from         = grid[start_i].u;
          double              best_f       = grid[start_i].value;
          double              initial_step = grid[start_i].step;
          for (int attempt = 0; attempt < 3; ++attempt)
            {
              std::vector<double> x = from;
              nlopt_opt opt = nlopt_create(dim >= 2 ? NLOPT_LN_BOBYQA : NLOPT_LN_COBYLA, dim);
              std::vector<double> lo(dim, 0.0), hi(dim, 1.0), step(dim, initial_step);
              step.back() = std::min(0.1, initial_step);
              nlopt_set_lower_bounds(opt, lo.data());
              nlopt_set_upper_bounds(opt, hi.data());
              nlopt_set_initial_step(opt, step.data());
              nlopt_set_min_objective(opt, objective, &o);
              nlopt_set_xtol_abs1(opt, ringing ? 2e-5 : 2e-4);
              nlopt_set_ftol_rel(opt, 1e-7);
              nlopt_set_maxeval(opt, ev.options.max_evaluations);
              double f = 0;
              status   = nlopt_optimize(opt, x.data(), &f);
              nlopt_destroy(opt);
              initial_step = ringing ? initial_step : 0.05;
              const bool gained = f < 0.99 * best_f;
              if (f < best_f)
                {
                  best_f = f;
                  from   = x;
                }
              if (!gained)
                break;
            }
        }
      c.message = "NLopt status " + std::to_string(static_cast<int>(status));
      const std::vector<double> x = o.best_u; // the best point seen (grid or optimisers)

      c.u           = x;
      c.values      = ev.values(x);
      c.force_gain  = ev.gain(x);
      c.k           = static_cast<int>(dim);
      c.evaluations = o.evaluations + short_runs;
      c.failed      = o.failures == o.evaluations;
      c.n_train     = o.n;
      c.ssr_train   = o.best * static_cast<double>(o.n);
      const double n = static_cast<double>(std::max<std::size_t>(o.n, 1));
      const double lnL = n * std::log(std::max(c.ssr_train, 1e-300) / n);
      c.bic         = lnL + c.k * std::log(n);
      c.aic         = lnL + 2.0 * c.k;
      try
        {
          predictions   = simulate_all(ev.parameters(x), ev.map, ev.runs, ev.options.relative_tolerance,
                                         ev.run_threads);
          c.rms_train   = pooled_rms(ev.runs, predictions, false);
          c.rms_heldout = pooled_rms(ev.runs, predictions, true);
        }
      catch (const std::exception &e)
        {
          c.failed  = true;
          c.message = e.what();
        }
      c.wall_time_s = seconds_since(start);
      return c;
    }

    std::map<std::string, double> pooled_norms(const std::vector<RunCase> &runs,
                                               const std::vector<Signals> &model, bool swings)
    {
      std::map<std::string, double> sum;
      std::map<std::string, int>    count;
      for (std::size_t r = 0; r < runs.size(); ++r)
        for (const auto &[name, v] :
             residual_norms(runs[r].run, model[r], swings ? runs[r].swings : runs[r].scales))
          {
            sum[name] += v * v;
            ++count[name];
          }
      for (auto &[name, v] : sum)
        v = std::sqrt(v / count[name]);
      return sum;
    }
  } // namespace

  RunCase make_run_case(MeasuredRun run, system::Scenario scenario, double frequency_Hz,
                        double training_fraction)
  {
    RunCase rc;
    rc.setup.scenario     = scenario;
    rc.setup.frequency_Hz = frequency_Hz > 0 ? frequency_Hz : run.drive_frequency_Hz();
    rc.swings             = signal_scales(run);
    rc.scales             = rc.swings;
    rc.drive_noise_sd     = white_noise_sd(run.signal(run.drive_column()));
    rc.n_train = std::max<std::size_t>(
      10, static_cast<std::size_t>(std::floor(training_fraction * static_cast<double>(run.time_s.size()))));
    rc.run = std::move(run);
    return rc;
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
      const auto       &rc = runs[i];
      SimulationOptions so;
      so.relative_tolerance = rtol;
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
            const double measured = white_noise_sd(rc.run.signal(name));
            rc.scales[name] = std::max(std::sqrt(measured * measured + response), 1e-3 * rc.swings.at(name));
          }
      }
  }

  DiagnosisResult diagnose(const system::SystemParameters &base_in, const system::ValveMaps &map,
                           std::vector<RunCase> runs, const DiagnoseOptions &options)
  {
    const auto start = Clock::now();
    if (runs.empty())
      throw InputError("diagnose: no measured runs given");
    const unsigned cores = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
    calibrate_noise(base_in, map, runs, options.relative_tolerance, cores);
    DiagnosisResult result;
    RunTraits       traits;
    traits.scenario      = runs.front().setup.scenario;
    traits.voltage_drive = runs.front().run.drive_column() == "voltage_V";
    for (const auto &rc : runs)
      if (rc.run.drive_column() != runs.front().run.drive_column())
        throw InputError("'" + rc.run.source + "' is driven by " + rc.run.drive_column() + ", '" +
                         runs.front().run.source + "' by " + runs.front().run.drive_column() +
                         ": give runs of one kind of drive");

    std::vector<std::shared_ptr<const Effect>> library;
    if (options.effects.empty())
      library = effect_library();
    else
      for (const auto &name : options.effects)
        library.push_back(find_effect(name));

    system::SystemParameters base = base_in;
    result.before = simulate_all(base, map, runs, options.relative_tolerance, cores);
    for (std::size_t r = 0; r < runs.size(); ++r)
      result.localisation.push_back(localise(runs[r].run, result.before[r],
                                             runs[r].setup.frequency_Hz, runs[r].swings));
    {
      std::vector<double> f, a, res;
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          f.push_back(runs[r].setup.frequency_Hz);
          const auto &d = runs[r].run.signal(runs[r].run.drive_column());
          a.push_back(*std::max_element(d.begin(), d.end()) - *std::min_element(d.begin(), d.end()));
          res.push_back(residual_norms(runs[r].run, result.before[r], runs[r].swings).at("overall"));
        }
      result.trend_sentences = trends(f, a, res);
    }
    std::vector<Signals> current = result.before;
    std::vector<std::string> named;

    for (int round = 0; round < std::max(1, options.rounds); ++round)
      {
        RoundResult rr;
        std::vector<const Effect *> todo{nullptr};
        for (const auto &e : library)
          if (std::find(named.begin(), named.end(), e->name()) == named.end())
            {
              const std::string why = e->not_testable(traits);
              if (why.empty())
                todo.push_back(e.get());
              else
                {
                  CandidateResult c;
                  c.effect       = e->name();
                  c.not_testable = why;
                  rr.candidates.push_back(c);
                }
            }
        std::vector<CandidateResult>      fitted(todo.size());
        std::vector<std::vector<Signals>> predictions(todo.size());
        std::mutex                        mutex; // for the progress lines
        parallel_for(todo.size(), cores, [&](std::size_t i) {
          Evaluator ev{base, map, runs, todo[i], options, 1, &current};
          fitted[i] = fit(ev, predictions[i]);
          if (options.progress)
            {
              std::lock_guard lock(mutex);
              char            buf[256];
              std::snprintf(buf, sizeof buf, "%-18s BIC %.6g, held-out RMS %.4g, %d runs of the model, %.1f s",
                            fitted[i].effect.c_str(), fitted[i].bic, fitted[i].rms_heldout,
                            fitted[i].evaluations, fitted[i].wall_time_s);
              options.progress(buf);
            }
        });

        const CandidateResult &none = fitted[0];
        double bic_min = 1e300;
        for (const auto &c : fitted)
          if (!c.failed)
            bic_min = std::min(bic_min, c.bic);
        double weight_sum = 0;
        for (const auto &c : fitted)
          if (!c.failed)
            weight_sum += std::exp(-0.5 * (c.bic - bic_min));
        // rank the effects by BIC
        std::vector<std::size_t> order;
        for (std::size_t i = 1; i < fitted.size(); ++i)
          if (!fitted[i].failed)
            order.push_back(i);
        std::sort(order.begin(), order.end(),
                  [&](auto a, auto b) { return fitted[a].bic < fitted[b].bic; });

        // the dominant feature of the residual before this round
        double worst = -1;
        std::string signal, half;
        for (std::size_t r = 0; r < runs.size(); ++r)
          {
            const auto L = localise(runs[r].run, current[r], runs[r].setup.frequency_Hz, runs[r].scales);
            const auto v = L.numbers[L.dominant_signal]["rms_normalised"].get<double>();
            if (v > worst)
              {
                worst  = v;
                signal = L.dominant_signal;
                half   = L.dominant_half;
              }
          }
        const auto feature = [&](const std::vector<Signals> &model) {
          double s = 0;
          for (std::size_t r = 0; r < runs.size(); ++r)
            {
              const double v = half_cycle_residual(runs[r].run, model[r], runs[r].setup.frequency_Hz,
                                                   signal, half, runs[r].scales);
              s += v * v;
            }
          return std::sqrt(s / static_cast<double>(runs.size()));
        };
        const double feature_before = feature(current);

        std::string reasons;
        for (std::size_t i : order)
          {
            const auto  &c     = fitted[i];
            const double delta = none.bic - c.bic;
            char         buf[512];
            if (delta <= options.bic_threshold)
              {
                std::snprintf(buf, sizeof buf, "%s: BIC better than none by only %.1f (needs > %.0f). ",
                              c.effect.c_str(), delta, options.bic_threshold);
                reasons += buf;
                break; // the rest rank lower still
              }
            if (!(c.rms_heldout < none.rms_heldout))
              {
                std::snprintf(buf, sizeof buf, "%s: held-out residual %.4g not below none's %.4g. ",
                              c.effect.c_str(), c.rms_heldout, none.rms_heldout);
                reasons += buf;
                continue;
              }
            const double after = feature(predictions[i]);
            if (!(after <= 0.5 * feature_before))
              {
                std::snprintf(buf, sizeof buf,
                              "%s: explains too little of the dominant feature (%s, %s half: %.3g -> %.3g). ",
                              c.effect.c_str(), signal.c_str(), half.c_str(), feature_before, after);
                reasons += buf;
                continue;
              }
            rr.effect     = c.effect;
            rr.values     = c.values;
            rr.force_gain = c.force_gain;
            rr.confidence = std::exp(-0.5 * (c.bic - bic_min)) / weight_sum;
            rr.signature_explained = true;
            std::snprintf(buf, sizeof buf,
                          "dominant residual feature (%s, %s half) %.3g -> %.3g of its swing", signal.c_str(),
                          half.c_str(), feature_before, after);
            rr.signature_detail = buf;
            std::snprintf(buf, sizeof buf,
                          "%s: BIC better than none by %.1f, held-out RMS %.4g vs none's %.4g, "
                          "next best %s by %.1f; ",
                          c.effect.c_str(), delta, c.rms_heldout, none.rms_heldout,
                          order.size() > 1 ? fitted[order[order[0] == i ? 1 : 0]].effect.c_str() : "-",
                          order.size() > 1 ? fitted[order[order[0] == i ? 1 : 0]].bic - c.bic : 0.0);
            rr.decision = std::string(buf) + rr.signature_detail;
            current     = predictions[i];
            // Refine: the residual scales hold the model's response to the
            // drive's noise, computed so far with the model as it was; the
            // named effect can change that response many-fold (a soft outlet
            // seal turns the outlet valve's jitter into outlet pressure's),
            // which weighs the signals wrongly and biases the parameter.
            // Recalibrate with the fitted model and refit locally, until the
            // parameters settle (iteratively reweighted least squares).
            std::vector<double> u = c.u;
            for (int pass = 0; pass < options.refine_passes; ++pass)
              {
                Evaluator ev{base, map, runs, todo[i], options, cores}; // one fit: its runs at once
                calibrate_noise(ev.parameters(u), map, runs, options.relative_tolerance, cores);
                std::vector<Signals> refined;
                const auto           r = fit(ev, refined, &u);
                if (r.failed)
                  break;
                double moved = std::abs(r.force_gain / rr.force_gain - 1.0);
                for (std::size_t j = 0; j < r.values.size(); ++j)
                  moved = std::max(moved, std::abs(r.values[j] / rr.values[j] - 1.0));
                u             = r.u;
                rr.values     = r.values;
                rr.force_gain = r.force_gain;
                current       = refined;
                ++rr.refine_passes;
                if (moved < 0.01)
                  break;
              }
            break;
          }
        if (rr.effect == "none")
          {
            rr.values     = {};
            rr.force_gain = none.force_gain;
            rr.confidence = std::exp(-0.5 * (none.bic - bic_min)) / weight_sum;
            rr.decision   = "no significant missing effect: " + reasons;
            current       = predictions[0];
          }
        for (auto &c : fitted)
          rr.candidates.push_back(c);
        result.rounds.push_back(rr);
        // the model the next round starts from
        if (rr.effect != "none")
          {
            find_effect(rr.effect)->apply(rr.values, base);
            named.push_back(rr.effect);
          }
        base.transducer.piezomagnetic_coefficient_m_per_A *= rr.force_gain;
        if (rr.effect == "none")
          break;
      }
    result.final_parameters = base;
    result.after            = current;
    result.residual_before  = pooled_norms(runs, result.before, false);
    result.residual_after   = pooled_norms(runs, result.after, false);
    result.swing_before     = pooled_norms(runs, result.before, true);
    result.swing_after      = pooled_norms(runs, result.after, true);
    result.runs             = runs;
    result.wall_time_s      = seconds_since(start);
    return result;
  }

  nlohmann::json to_json(const DiagnosisResult &r, const std::vector<RunCase> &runs)
  {
    using nlohmann::json;
    const auto &first = r.rounds.front();
    json        parameters = json::object();
    json        rounds     = json::array();
    for (const auto &rr : r.rounds)
      {
        json p = json::object();
        if (rr.effect != "none")
          {
            const auto e = find_effect(rr.effect);
            for (std::size_t i = 0; i < rr.values.size(); ++i)
              p[e->parameters()[i].key] = rr.values[i];
          }
        json candidates = json::array();
        for (const auto &c : rr.candidates)
          {
            json cp = json::object();
            if (c.effect != "none" && c.not_testable.empty())
              {
                const auto e = find_effect(c.effect);
                for (std::size_t i = 0; i < c.values.size(); ++i)
                  cp[e->parameters()[i].key] = c.values[i];
              }
            json cj = {{"effect", c.effect}, {"parameters", cp}};
            if (!c.not_testable.empty())
              cj["not_testable"] = c.not_testable;
            else
              {
                cj["force_gain"]   = c.force_gain;
                cj["k"]            = c.k;
                cj["bic"]          = c.bic;
                cj["aic"]          = c.aic;
                cj["rms_train"]    = c.rms_train;
                cj["rms_heldout"]  = c.rms_heldout;
                cj["evaluations"]  = c.evaluations;
                cj["wall_time_s"]  = c.wall_time_s;
                cj["failed"]       = c.failed;
                cj["optimiser"]    = c.message;
              }
            candidates.push_back(cj);
          }
        rounds.push_back({{"effect", rr.effect},
                          {"parameters", p},
                          {"force_gain", rr.force_gain},
                          {"confidence", rr.confidence},
                          {"decision", rr.decision},
                          {"signature_explained", rr.signature_explained},
                          {"signature", rr.signature_detail},
                          {"refits_with_rescaled_residuals", rr.refine_passes},
                          {"candidates", candidates}});
        if (&rr == &first)
          parameters = p;
      }
    json localisation = json::array();
    for (std::size_t i = 0; i < runs.size(); ++i)
      localisation.push_back({{"run", runs[i].run.source},
                              {"frequency_Hz", runs[i].setup.frequency_Hz},
                              {"sentences", r.localisation[i].sentences},
                              {"numbers", r.localisation[i].numbers}});
    double shrink = 0;
    if (r.residual_before.at("overall") > 0)
      shrink = 1.0 - r.residual_after.at("overall") / r.residual_before.at("overall");
    return {{"effect", first.effect},
            {"parameters", parameters},
            {"confidence", first.confidence},
            {"decision", first.decision},
            {"residual_before", r.residual_before},
            {"residual_after", r.residual_after},
            {"residual_shrink", shrink},
            {"residual_before_fraction_of_swing", r.swing_before},
            {"residual_after_fraction_of_swing", r.swing_after},
            {"candidates", rounds.front()["candidates"]},
            {"rounds", rounds},
            {"localisation", localisation},
            {"trends", r.trend_sentences},
            {"wall_time_s", r.wall_time_s},
            {"definitions",
             {{"residual", "RMS of (model - data) / (the signal's expected noise: its white noise and the "
                           "model's response to the drive's noise), per signal over every run; overall: RMS "
                           "over the signals. About 1 when the model explains the data to within its noise"},
              {"residual_before_fraction_of_swing", "the same residual over the measured signal's RMS about its mean"},
              {"bic", "n ln(SSR/n) + k ln n on the training samples (first part of each run)"},
              {"aic", "n ln(SSR/n) + 2k"},
              {"rms_heldout", "normalised RMS residual on the last part of each run, unseen by the fit"},
              {"confidence", "BIC weight exp(-BIC/2) / sum over the candidates"},
              {"force_gain", "nuisance: the rod's force per ampere times this, fitted with every candidate"}}}};
  }
} // namespace rectify::diagnosis
