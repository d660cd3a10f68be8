#include "diagnosis/search.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace rectify::diagnosis
{
  std::vector<bool> grid_valleys(const std::vector<int> &line, const std::vector<int> &at,
                                 const std::vector<double> &value)
  {
    if (line.size() != at.size() || line.size() != value.size())
      throw std::logic_error("grid_valleys: lines, positions and values differ in length");
    std::vector<bool> valley(value.size(), false);
    for (std::size_t i = 0; i < value.size(); ++i)
      {
        if (line[i] < 0)
          continue;
        bool lowest = true;
        for (std::size_t j = 0; j < value.size() && lowest; ++j)
          if (j != i && line[j] == line[i] && std::abs(at[j] - at[i]) == 1 && value[j] < value[i])
            lowest = false;
        valley[i] = lowest;
      }
    return valley;
  }

  double uncertain_from_unit(const system::UncertainParameter &q, double u)
  {
    if (q.off_at_zero && !(u > 0.0)) // the case's 0: off
      return 0.0;
    // clamped: lower * (upper / lower)^1 can round past upper, and the new
    // case file's value must lie inside its own [uncertain] range
    return std::clamp(q.lower * std::pow(q.upper / q.lower, std::clamp(u, 0.0, 1.0)), q.lower, q.upper);
  }

  double uncertain_to_unit(const system::UncertainParameter &q, double v)
  {
    if (!(v > q.lower)) // also 0, a value the case leaves out (off_at_zero)
      return 0.0;
    return std::clamp(std::log(v / q.lower) / std::log(q.upper / q.lower), 0.0, 1.0);
  }

  CoreUse &core_use()
  {
    static CoreUse use;
    return use;
  }

  /// The runs' mean share of the white noise's power inside the compared
  /// band (of the Nyquist band).
  double mean_band_fraction(const std::vector<RunCase> &runs)
  {
    double fraction = 0;
    for (const auto &rc : runs)
      fraction += rc.band_fraction / static_cast<double>(runs.size());
    return fraction;
  }

  /// Band-limited residuals are correlated: n samples of the runs carry
  /// about n x (the band's share of the Nyquist band) independent values.
  double independent_values(const std::vector<RunCase> &runs, std::size_t n)
  {
    return std::max(1.0, static_cast<double>(n) * mean_band_fraction(runs));
  }

  Outcome evaluate(const Evaluator &ev, const std::vector<double> &u)
  {
    Outcome out;
    try
      {
        out.r = ev.training(u);
      }
    catch (const std::exception &)
      {
        out.failed = true;
      }
    return out;
  }

  namespace
  {
    /// The same point to the last bit (a value evaluated ahead stands for
    /// this one only then).
    bool same_bits(const std::vector<double> &a, const double *b, std::size_t n)
    {
      return a.size() == n && std::memcmp(a.data(), b, n * sizeof(double)) == 0;
    }

    nlopt_opt make_search(unsigned dim, const std::vector<double> &step, double xtol_abs, double ftol_rel,
                          int max_evaluations)
    {
      nlopt_opt           opt = nlopt_create(dim >= 2 ? NLOPT_LN_BOBYQA : NLOPT_LN_COBYLA, dim);
      std::vector<double> lo(dim, 0.0), hi(dim, 1.0);
      nlopt_set_lower_bounds(opt, lo.data());
      nlopt_set_upper_bounds(opt, hi.data());
      nlopt_set_initial_step(opt, step.data());
      nlopt_set_xtol_abs1(opt, xtol_abs);
      nlopt_set_ftol_rel(opt, ftol_rel);
      nlopt_set_maxeval(opt, max_evaluations);
      return opt;
    }

    double record_point(unsigned n, const double *x, double *, void *data)
    {
      static_cast<std::vector<std::vector<double>> *>(data)->emplace_back(x, x + n);
      return 0.0;
    }

    double valley_objective(unsigned n, const double *x, double *, void *data)
    {
      const auto         *v = static_cast<Valley *>(data);
      std::vector<double> u(x, x + n);
      const auto          a = v->at(u, v->f_peak * std::exp(0.1 * (2.0 * x[0] - 1.0)));
      if (!a)
        return 1e6; // no value of the parameter rings there: as a failed run
      u[0] = *a;
      return objective(n, u.data(), nullptr, v->o);
    }
  } // namespace

  double objective(unsigned n, const double *x, double *, void *data)
  {
    auto *o = static_cast<Objective *>(data);
    std::vector<double> u(x, x + n);
    ++o->evaluations;
    Outcome e;
    if (o->ahead && o->ahead_next < o->ahead->size() && same_bits((*o->ahead)[o->ahead_next].u, x, n))
      {
        e = (*o->ahead)[o->ahead_next++].outcome;
        ++core_use().handed_over;
      }
    else
      {
        o->ahead = nullptr;
        e        = evaluate(*o->evaluator, u);
      }
    double value = 0;
    if (!e.failed)
      {
        o->n  = e.r.n;
        value = e.r.sum / static_cast<double>(std::max<std::size_t>(e.r.n, 1));
      }
    if (e.failed || !std::isfinite(value))
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

  /// A local minimisation over [0, 1]^n from x (left at the result, its
  /// value in *value): BOBYQA, or COBYLA in one dimension (BOBYQA needs
  /// two), with first steps `step` per coordinate.
  ///
  /// BOBYQA's first 2n + 1 points (its start, and a first step either way
  /// along each coordinate) are set by the start, the steps and the bounds
  /// alone, not by the values it sees there (NLopt's prelim_). Where the
  /// search is objective()'s and a core is idle (a search that runs
  /// alone: a refit, a profile's last side), they are evaluated ahead, at
  /// once: a search on a recorder, stopped after them, gives the points
  /// to the last bit, and objective() hands their values over in the
  /// search's order. The points, values, tally and result are those of
  /// the search alone; only its time is less.
  nlopt_result minimise_in_unit_box(nlopt_func f, void *data, std::vector<double> &x,
                                    const std::vector<double> &step, double xtol_abs, double ftol_rel,
                                    int max_evaluations, double *value)
  {
    const auto         dim   = static_cast<unsigned>(x.size());
    auto              *o     = f == objective ? static_cast<Objective *>(data) : nullptr;
    const int          first = max_evaluations > 0 ?
                                 std::min<int>(2 * static_cast<int>(dim) + 1, max_evaluations) :
                                 2 * static_cast<int>(dim) + 1;
    std::vector<Ahead> ahead;
    // an evaluation that already keeps every core busy (its runs at once) gains nothing
    const bool runs_fill = o && o->evaluator->run_threads > 1 && o->evaluator->runs.size() > 1;
    if (o && dim >= 2 && !runs_fill)
      if (const int helpers = core_use().take_idle(first - 1); helpers > 0)
        {
          std::vector<std::vector<double>> points;
          nlopt_opt                        recorder = make_search(dim, step, xtol_abs, ftol_rel, first);
          nlopt_set_min_objective(recorder, record_point, &points);
          std::vector<double> x0 = x;
          double              unused;
          nlopt_optimize(recorder, x0.data(), &unused);
          nlopt_destroy(recorder);
          // the cores taken go back to parallel_for, which counts its own
          core_use().give_back(helpers);
          ahead.resize(points.size());
          parallel_for(points.size(), 1 + static_cast<unsigned>(helpers), [&](std::size_t i) {
            ahead[i] = {points[i], evaluate(*o->evaluator, points[i])};
          });
          o->ahead      = &ahead;
          o->ahead_next = 0;
        }
    nlopt_opt opt = make_search(dim, step, xtol_abs, ftol_rel, max_evaluations);
    nlopt_set_min_objective(opt, f, data);
    const nlopt_result status = nlopt_optimize(opt, x.data(), value);
    nlopt_destroy(opt);
    if (o)
      o->ahead = nullptr;
    return status;
  }

  /// objective() at each point, up to `threads` at once, folded into o in
  /// the points' order: o ends as if they had been evaluated one by one.
  std::vector<double> evaluate_points(Objective &o, const std::vector<std::vector<double>> &points,
                                      unsigned threads)
  {
    std::vector<Objective> each(points.size(), Objective{o.evaluator, 0, 0, 0, 1e300, {}});
    std::vector<double>    values(points.size());
    parallel_for(points.size(), threads, [&](std::size_t i) {
      auto u    = points[i];
      values[i] = objective(static_cast<unsigned>(u.size()), u.data(), nullptr, &each[i]);
    });
    for (const auto &e : each) // each one evaluation: its best is values[i] at points[i]
      o.absorb(e);
    return values;
  }


  void valley_search(Valley valley, std::vector<double> from, int max_evaluations)
  {
    from[0] = 0.5; // f_peak, where `from` rings
    std::vector<double> step(from.size(), 0.05);
    step[0] = 0.02; // 0.4 % of the frequency
    double f = 0;
    minimise_in_unit_box(valley_objective, &valley, from, step, 1e-3, 1e-4, max_evaluations, &f);
  }

  std::vector<Signals> simulate_all(const system::SystemParameters &p,
                                    const system::ValveMaps &map,
                                    const std::vector<RunCase> &runs, double rtol, unsigned threads)
  {
    std::vector<Signals> out(runs.size());
    parallel_for(runs.size(), threads, [&](std::size_t i) {
      out[i] = simulate_run(p, map, runs[i].run, runs[i].setup, runs[i].simulation(rtol));
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
                                   squared_residual(rc.run, model[r], rc.scales, rc.n_skip, rc.n_train);
        total.sum += s.sum;
        total.n += s.n;
      }
    return std::sqrt(total.sum / static_cast<double>(std::max<std::size_t>(total.n, 1)));
  }
} // namespace rectify::diagnosis
