// The search over a candidate's parameters (a stage of diagnose()).
//
// Takes: the runs (RunCase, with their scales), the baseline's parameters,
// a candidate effect or none, the options.
// Gives: Evaluator, the model's parameters and training residual at a point
// u of the unit box [0, 1]^k (the effect's parameters, the free [uncertain]
// ones, the force gain); the objective NLopt minimises over it and the
// local search (BOBYQA, COBYLA in one dimension); the cores a search may
// borrow while others wait (CoreUse); parallel_for over independent runs.
#pragma once

#include <nlopt.h>

#include <atomic>
#include <chrono>
#include <exception>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "diagnosis/effect.h"
#include "diagnosis/options.h"
#include "diagnosis/results.h"
#include "diagnosis/runs.h"
#include "maps/resistance_map.h"

namespace rectify::diagnosis
{
  using Clock = std::chrono::steady_clock;

  /// The valleys of a candidate's start grid: point i lies on grid line
  /// line[i] (one line per baseline the effect's parameter is stepped
  /// from; -1: not on a grid) at position at[i], with objective value[i].
  /// A point on a line is a valley where no neighbour on its line (at[i]
  /// +- 1) is lower; points off the grid are not.
  std::vector<bool> grid_valleys(const std::vector<int> &line, const std::vector<int> &at,
                                 const std::vector<double> &value);

  /// An [uncertain] parameter <-> its position in [0, 1] (log over its
  /// bounds); the value always lies within its bounds, or is 0 at
  /// position 0 for one the case leaves out (off_at_zero).
  double uncertain_from_unit(const system::UncertainParameter &q, double u);
  double uncertain_to_unit(const system::UncertainParameter &q, double v);


  inline double seconds_since(Clock::time_point start)
  {
    return std::chrono::duration<double>(Clock::now() - start).count();
  }

  /// The cores a diagnosis may use (DiagnoseOptions::threads) and how many
  /// threads compute at the moment: parallel_for's workers count while they
  /// take tasks, its caller not while it waits for them. A search that
  /// finds a core idle evaluates its first points ahead on it
  /// (minimise_in_unit_box). 0 cores: none is lent.
  struct CoreUse
  {
    std::atomic<int> cores{0};
    std::atomic<int> computing{1};
    std::atomic<int> handed_over{0}; ///< values evaluated ahead that a search took

    /// Takes up to `wanted` idle cores; returns how many it took.
    int take_idle(int wanted)
    {
      int now = computing.load();
      for (;;)
        {
          const int idle = std::min(wanted, cores.load() - now);
          if (idle <= 0)
            return 0;
          if (computing.compare_exchange_weak(now, now + idle))
            return idle;
        }
    }
    void give_back(int n) { computing -= n; }
  };


  /// The one CoreUse of the process (a diagnosis sets its cores).
  CoreUse &core_use();

  /// fn(i) for i in [0, n) on up to `threads` threads; rethrows the first
  /// exception. The runs of one evaluation are independent simulations.
  /// Where fewer threads can be started, those that did (or the caller)
  /// take every task.
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
    const auto               worker = [&] {
      core_use().computing += 1;
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
      core_use().give_back(1);
    };
    std::vector<std::thread> pool;
    core_use().give_back(1); // the caller waits
    for (unsigned t = 0; t < threads; ++t)
      try
        {
          pool.emplace_back(worker);
        }
      catch (const std::system_error &)
        {
          break;
        }
    if (pool.empty())
      worker();
    for (auto &t : pool)
      t.join();
    core_use().computing += 1;
    if (error)
      std::rethrow_exception(error);
  }

  /// Parameters at a point u in [0, 1]^k: the effect's parameters, then
  /// the free baseline ([uncertain]) parameters, then the force gain.
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
    /// Threads for a batch of independent evaluations (ringing_start's grids).
    unsigned                        batch_threads = 1;
    /// Indices into base.uncertain fitted here; the others sit at `held`.
    std::vector<std::size_t>        free;
    std::vector<double>             held;  ///< per base.uncertain: its position when not free
    std::vector<double>             nuisance_start; ///< free ones' positions, then the gain's (0.5: 1)
    /// Per base.uncertain: true where the effect sets the same key (a
    /// case's [uncertain] second mode and reed_second_mode): the effect's
    /// value wins, and the baseline parameter is neither fitted nor
    /// applied. Empty: none.
    std::vector<bool>               superseded;
    /// > 0: the objective of none's fit (mean square in noise units); a
    /// candidate's searches are then restarted only where their first
    /// runs came near enough to closing the gap above the noise that none
    /// leaves (fit(): restart_closure).
    double                          none_objective = 0;

    /// An evaluator with every [uncertain] parameter free, starting at the
    /// case's values; but one the case leaves out (off_at_zero), which is
    /// held off: the named effect's fit tries it on (calibrate_left_out);
    /// and one that does nothing in the case's model (the friction's
    /// shape without friction: inert_reason (diagnosis/effect.h)), held at
    /// the case's value: a named effect that makes it act may free it
    /// (free_determined).
    static Evaluator make(const system::SystemParameters &base, const system::ValveMaps &map,
                          const std::vector<RunCase> &runs, const Effect *effect,
                          const DiagnoseOptions &options, unsigned run_threads,
                          const std::vector<Signals> *reference = nullptr)
    {
      Evaluator ev{base, map, runs, nullptr, options, run_threads, reference, 0.0, 1, {}, {}, {}, {}};
      for (std::size_t j = 0; j < base.uncertain.size(); ++j)
        {
          const auto &q = base.uncertain[j];
          ev.held.push_back(uncertain_to_unit(q, base.real_value(q.table, q.key)));
          if (q.off_at_zero && !(base.real_value(q.table, q.key) > 0.0)) // (a later round may have it on)
            continue;
          if (!inert_reason(base, q.table, q.key).empty())
            continue;
          ev.free.push_back(j);
          ev.nuisance_start.push_back(ev.held.back());
        }
      ev.nuisance_start.push_back(0.5);
      ev.use_effect(effect);
      return ev;
    }

    bool is_superseded(std::size_t j) const { return j < superseded.size() && superseded[j]; }
    /// At positions w, base.uncertain[j] is one the case leaves out and
    /// still off: not part of this model (not fitted, freed or profiled;
    /// its position 0 is a step, not a slope).
    bool is_off(std::size_t j, const std::vector<double> &w) const
    {
      return base.uncertain[j].off_at_zero && !(w[j] > 0.0);
    }

    /// The candidate `e` (null: none) in this evaluator's space: the
    /// [uncertain] parameters it sets itself leave the free set. Called
    /// on the baseline's evaluator (or a copy of it), whose free set
    /// has none superseded.
    void use_effect(const Effect *e)
    {
      effect = e;
      superseded.assign(base.uncertain.size(), false);
      for (std::size_t j = 0; e && j < base.uncertain.size(); ++j)
        superseded[j] = e->sets(base.uncertain[j].table, base.uncertain[j].key);
      std::vector<std::size_t> kept;
      std::vector<double>      start; // nuisance_start: one per free parameter, then the gain's
      for (std::size_t i = 0; i < free.size(); ++i)
        if (!is_superseded(free[i]))
          {
            kept.push_back(free[i]);
            start.push_back(nuisance_start[i]);
          }
      start.push_back(nuisance_start.back());
      free           = kept;
      nuisance_start = start;
    }

    std::size_t samples(const RunCase &rc) const
    {
      if (!(horizon_cycles > 0))
        return rc.n_train;
      const auto  &t  = rc.run.time_s;
      const double dt = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
      // the cycles' samples and one more, as the quotient's rounding falls
      // (dt is read off the time column): a window of N cycles of m
      // samples holds N m or N m + 1: the last sample of a short window
      // (the ringing search's 3 and 6 cycles) stays in it
      const auto   n  = static_cast<std::size_t>(horizon_cycles / (rc.setup.frequency_Hz * dt)) + 1;
      return std::min(rc.n_train, rc.n_skip + n);
    }

    std::size_t n_effect() const { return effect ? effect->parameters().size() : 0; }
    std::size_t dimension() const { return n_effect() + free.size() + 1; }

    std::vector<double> start_point() const
    {
      std::vector<double> u(n_effect(), 0.5);
      u.insert(u.end(), nuisance_start.begin(), nuisance_start.end());
      return u;
    }

    /// The start point with the free baseline parameters at the case's
    /// values and the gain at 1.
    std::vector<double> prior_point() const
    {
      std::vector<double> u(n_effect(), 0.5);
      for (std::size_t j : free)
        {
          const auto &q = base.uncertain[j];
          u.push_back(uncertain_to_unit(q, base.real_value(q.table, q.key)));
        }
      u.push_back(0.5);
      return u;
    }

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
    /// Every [uncertain] parameter's position at u.
    std::vector<double> uncertain_units(const std::vector<double> &u) const
    {
      std::vector<double> w = held;
      for (std::size_t i = 0; i < free.size(); ++i)
        w[free[i]] = u[n_effect() + i];
      return w;
    }
    std::map<std::string, double> baseline(const std::vector<double> &u) const
    {
      std::map<std::string, double> out;
      const auto                    w = uncertain_units(u);
      for (std::size_t j = 0; j < base.uncertain.size(); ++j)
        if (!is_superseded(j))
          out[base.uncertain[j].name()] = uncertain_from_unit(base.uncertain[j], w[j]);
      return out;
    }
    system::SystemParameters parameters(const std::vector<double> &u) const
    {
      system::SystemParameters p = base;
      const auto               w = uncertain_units(u);
      for (std::size_t j = 0; j < base.uncertain.size(); ++j)
        if (!is_superseded(j))
          *p.real_field(base.uncertain[j].table, base.uncertain[j].key) =
            uncertain_from_unit(base.uncertain[j], w[j]);
      if (effect)
        effect->apply(values(u), p);
      p.transducer.piezomagnetic_coefficient_m_per_A *= gain(u);
      return p;
    }
    /// The normalised residuals over the training samples, appended run by run.
    std::vector<double> residual_vector(const std::vector<double> &u) const
    {
      const auto                       p = parameters(u);
      std::vector<std::vector<double>> per_run(runs.size());
      parallel_for(runs.size(), run_threads, [&](std::size_t i) {
        const auto &rc = runs[i];
        auto        so = rc.simulation(options.relative_tolerance);
        so.n_samples   = samples(rc);
        const auto model = simulate_run(p, map, rc.run, rc.setup, so);
        append_residuals(rc.run, model, rc.scales, rc.n_skip, so.n_samples, per_run[i]);
      });
      std::vector<double> all;
      for (const auto &r : per_run)
        all.insert(all.end(), r.begin(), r.end());
      return all;
    }
    /// Sum of squared normalised residuals over the training samples.
    SquaredResidual training(const std::vector<double> &u) const
    {
      SquaredResidual total;
      for (double e : residual_vector(u))
        {
          total.sum += e * e;
          ++total.n;
        }
      return total;
    }
  };

  /// One evaluation of the model: its training residual, or a run that
  /// failed to integrate.
  struct Outcome
  {
    bool            failed = false;
    SquaredResidual r;
  };

  /// A point evaluated ahead of the search that will ask for it.
  struct Ahead
  {
    std::vector<double> u;
    Outcome             outcome;
  };

  struct Objective
  {
    const Evaluator *evaluator;
    int              evaluations = 0;
    int              failures    = 0;
    std::size_t      n           = 0;
    double           best        = 1e300;
    std::vector<double> best_u;
    /// The search's next points, evaluated ahead (minimise_in_unit_box),
    /// in the order it asks for them; dropped at the first it does not.
    const std::vector<Ahead> *ahead      = nullptr;
    std::size_t               ahead_next = 0;

    /// Adds a search's tally made with its own Objective (another thread's),
    /// keeping the better best point.
    void absorb(const Objective &part)
    {
      evaluations += part.evaluations;
      failures += part.failures;
      n = part.n ? part.n : n;
      if (part.best < best)
        {
          best   = part.best;
          best_u = part.best_u;
        }
    }
  };

  /// A local search along a valley of constant ringing: BOBYQA over the
  /// baseline and the gain (u[1..]) with the effect's first parameter
  /// set, at each step, to the value that rings at f there; f itself
  /// within +-10 % of f_peak (u[0] of the search). Along the baseline a
  /// fixed parameter would cross the comb of basins that its ringing's
  /// phase makes; at a fixed frequency the objective is smooth there.
  /// Evaluations go into `o` (in the parameter's own coordinates).
  struct Valley
  {
    Objective *o;
    /// the parameter's position that rings at a frequency with the rest at u
    std::function<std::optional<double>(const std::vector<double> &u, double f)> at;
    double f_peak;
  };

  /// The runs' mean share of the white noise's power inside the compared
  /// band (of the Nyquist band).
  double mean_band_fraction(const std::vector<RunCase> &runs);

  /// Band-limited residuals are correlated: n samples of the runs carry
  /// about n x (the band's share of the Nyquist band) independent values.
  double independent_values(const std::vector<RunCase> &runs, std::size_t n);

  /// The model at u: its training residual, or a run that failed.
  Outcome evaluate(const Evaluator &ev, const std::vector<double> &u);

  /// NLopt's objective over an Objective (data): the mean square training
  /// residual at x, 1e6 where the model fails to integrate.
  double objective(unsigned n, const double *x, double *, void *data);

  /// A local minimisation over [0, 1]^n from x (left at the result, its
  /// value in *value): BOBYQA, or COBYLA in one dimension, with first steps
  /// `step` per coordinate; its first points evaluated ahead on idle cores
  /// where f is objective() (search.cpp).
  nlopt_result minimise_in_unit_box(nlopt_func f, void *data, std::vector<double> &x,
                                    const std::vector<double> &step, double xtol_abs, double ftol_rel,
                                    int max_evaluations, double *value);

  /// objective() at each point, up to `threads` at once, folded into o in
  /// the points' order: o ends as if they had been evaluated one by one.
  std::vector<double> evaluate_points(Objective &o, const std::vector<std::vector<double>> &points,
                                      unsigned threads);

  /// A local search along the valley of constant ringing through `from`.
  void valley_search(Valley valley, std::vector<double> from, int max_evaluations);

  /// Every run simulated with the model p, `threads` at once.
  std::vector<Signals> simulate_all(const system::SystemParameters &p, const system::ValveMaps &map,
                                    const std::vector<RunCase> &runs, double rtol, unsigned threads = 1);

  /// RMS of the normalised residuals of every run, pooled: over the
  /// training samples, or over the held-out ones.
  double pooled_rms(const std::vector<RunCase> &runs, const std::vector<Signals> &model, bool heldout);
} // namespace rectify::diagnosis
