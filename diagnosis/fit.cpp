#include "diagnosis/fit.h"

#include <chrono>
#include <optional>

#include "diagnosis/ringing_start.h"

namespace rectify::diagnosis
{
  /// Fits ev's candidate: from a coarse grid over the effect's first
  /// parameter (gain 1), or, when `from_point` is given (a point in
  /// [0, 1]^k), locally from there with first steps of `first_step` (of
  /// each position's [0, 1] range).
  CandidateResult fit(const Evaluator &ev, std::vector<Signals> &predictions,
                      const std::vector<double> *from_point, double first_step,
                      int max_attempts)
  {
    const auto      start = Clock::now();
    CandidateResult c;
    c.effect = ev.effect ? ev.effect->name() : "none";
    Objective o{&ev, 0, 0, 0, 1e300, {}};
    const unsigned dim = static_cast<unsigned>(ev.dimension());
    std::vector<double> u = ev.start_point();
    struct Start
    {
      double              value; ///< the objective there
      std::vector<double> u;
      double              step;  ///< BOBYQA's first step from there
      bool                from_ringing = false; ///< ringing_start's point: always refined
      int                 line = -1; ///< the grid line (one per base) it lies on, -1: not on a grid
      int                 at   = 0;  ///< its position along that line
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
    if (from_point && from_point->size() != dim)
      throw std::logic_error("diagnose: a fit's start point has " + std::to_string(from_point->size()) +
                             " coordinates, its candidate " + std::to_string(dim));
    if (from_point)
      add_start(*from_point, ringing ? fine_step(*from_point) : first_step);
    else if (ev.effect)
      {
        // the grid with the baseline as the baseline fit left it, and (if
        // different) at the case's values: a missing effect can pull the
        // baseline fit far from where the effect's own fit lies
        std::vector<std::vector<double>> bases{u};
        if (const auto prior = ev.prior_point(); prior != u)
          bases.push_back(prior);
        for (std::size_t l = 0; l < bases.size(); ++l)
          for (int g = 0; g < grid_points; ++g)
            {
              auto b = bases[l];
              b[0]   = (g + 0.5) / grid_points;
              add_start(b, 0.5 / grid_points);
              grid.back().line = static_cast<int>(l);
              grid.back().at   = g;
            }
        if (ringing)
          {
            const auto began = Clock::now();
            for (const auto &r : ringing_start(ev, short_runs, c.ringing_note))
              {
                add_start(r, fine_step(r));
                grid.back().from_ringing = true;
              }
            c.ringing_runs   = short_runs;
            c.ringing_time_s = seconds_since(began);
          }
      }
    else
      add_start(u, 0.5 / grid_points);
    std::stable_sort(grid.begin(), grid.end(), [](const Start &a, const Start &b) { return a.value < b.value; });
    const double best_start = grid.front().value;
    // the grid's valleys first (each the lowest of its neighbours along its
    // line), then the other points, each group by its value
    {
      std::vector<int>    line, at;
      std::vector<double> value;
      for (const auto &g : grid)
        {
          line.push_back(g.line);
          at.push_back(g.at);
          value.push_back(g.value);
        }
      const std::vector<bool> valley = grid_valleys(line, at, value);
      std::vector<Start>      ordered;
      for (const bool first : {true, false})
        for (std::size_t i = 0; i < grid.size(); ++i)
          if (valley[i] == first)
            ordered.push_back(grid[i]);
      grid = std::move(ordered);
    }
    // BOBYQA from the two best of the grid's valleys (the residual of a
    // valve that opens by a small pressure difference can have several
    // basins, and two neighbouring points of one valley are one start:
    // piston_friction-4's friction, 4.6 N, lies in the valley at 6.8 N of
    // the grid at the case's values, while the two best points overall,
    // 0.3 and 0.7 N at the baseline's fit, are one basin), and from
    // ringing_start's points wherever they rank (their basins are narrow,
    // and a coarse grid point can be lower on a 16-cycle objective while
    // lying in another basin). The searches are independent: they run
    // ev.batch_threads at a time, each with its own tally, folded in
    // order (the same best point as one after another).
    // Then each search within `restart_reach` of the best is restarted
    // (smaller first step) from its best point while a restart still
    // gains 1 %: the objective is slightly rough at the integrator's
    // tolerance, which can stop a trust region early in a curved valley
    // (effect vs force gain). A search left further behind is not: in
    // the bench's records a restart gained at most 12 %, so it could not
    // overtake, and its restarts were up to a fifth of a candidate's runs.
    const std::size_t        starts = std::min<std::size_t>(grid.size(), ev.effect ? 2 : 1);
    std::vector<std::size_t> chosen;
    for (std::size_t start_i = 0; start_i < grid.size(); ++start_i)
      if (start_i < starts || grid[start_i].from_ringing)
        chosen.push_back(start_i);
    struct Search
    {
      std::vector<double> from;    ///< the best point so far
      double              best_f;  ///< its value
      double              step;    ///< the next attempt's first step
      bool                gained;  ///< the last attempt gained 1 %
    };
    std::vector<Search> search(chosen.size());
    for (std::size_t k = 0; k < chosen.size(); ++k)
      search[k] = {grid[chosen[k]].u, grid[chosen[k]].value, grid[chosen[k]].step, true};
    std::vector<Objective>    searched(chosen.size(), Objective{&ev, 0, 0, 0, 1e300, {}});
    std::vector<nlopt_result> statuses(chosen.size(), NLOPT_SUCCESS);
    const auto attempt = [&](std::size_t k) {
      Search             &s = search[k];
      std::vector<double> x = s.from;
      std::vector<double> step(dim, s.step);
      for (std::size_t j = ev.n_effect(); j < dim; ++j) // the nuisance
        step[j] = std::min(0.1, s.step);
      double f    = 0;
      statuses[k] = minimise_in_unit_box(objective, &searched[k], x, step, ringing ? 2e-5 : 2e-4, 1e-7,
                                         ev.options.max_evaluations + 10 * static_cast<int>(ev.free.size()),
                                         &f);
      s.step   = ringing ? s.step : 0.05;
      s.gained = f < 0.99 * s.best_f;
      if (f < s.best_f)
        {
          s.best_f = f;
          s.from   = x;
        }
    };
    parallel_for(chosen.size(), ev.batch_threads, attempt);
    // A candidate is named only where it closes min_gap_closed of the gap
    // above the noise that none leaves (diagnose()). One whose first
    // searches leave it far from that is not restarted: on the bench's
    // loaded records the restarts of the candidates not named were up to
    // 255 runs each, up to half of their runs, and took at most 7 % off
    // the objective's part above the noise (f - 1), where reaching
    // min_gap_closed from restart_closure of it takes 61 %. The named
    // effect's first searches can end far from its best (piston_friction-0:
    // f - 1 from 6.1 to 0.9 in its restarts), but after closing most of the
    // gap already (67 %), and with a first search that took 88 % off. So
    // restarts are skipped only where both: the first searches closed less
    // than restart_closure x min_gap_closed, and even two more searches
    // each as good as the first (f - 1 falling by the same ratio again)
    // would stay short of min_gap_closed. The candidate's BIC is then that
    // of its first searches; the report says so.
    if (ev.effect && !from_point && gap_above_noise(ev.none_objective) > 0 && !search.empty() && max_attempts > 1)
      {
        double first = 1e300;
        for (const auto &s : search)
          first = std::min(first, s.best_f);
        const double from      = best_start;
        const double ratio     = from > 1.0 ? std::clamp((first - 1.0) / (from - 1.0), 0.0, 1.0) : 0.0;
        const double projected = 1.0 + (first - 1.0) * std::pow(ratio, max_attempts - 1);
        const double closed    = 1.0 - gap_above_noise(first) / gap_above_noise(ev.none_objective);
        const double reachable = 1.0 - gap_above_noise(projected) / gap_above_noise(ev.none_objective);
        const double restart   = restart_closure * ev.options.min_gap_closed;
        if (closed < restart && reachable < ev.options.min_gap_closed)
          {
            max_attempts = 1;
            char buf[320];
            std::snprintf(buf, sizeof buf,
                          "not restarted: its first searches close %.0f %% of the gap above the noise that none "
                          "leaves, %.0f %% if two more gained as much (%.0f %% needed to be restarted, %.0f %% "
                          "to be named)",
                          std::max(0.0, 100 * closed), std::max(0.0, 100 * reachable), 100 * restart,
                          100 * ev.options.min_gap_closed);
            c.search_note = buf;
          }
      }
    constexpr double restart_reach = 1.25;
    for (int a = 1; a < max_attempts; ++a)
      {
        double best = 1e300;
        for (const auto &s : search)
          best = std::min(best, s.best_f);
        std::vector<std::size_t> again;
        for (std::size_t k = 0; k < search.size(); ++k)
          if (search[k].gained && search[k].best_f <= restart_reach * best)
            again.push_back(k);
        parallel_for(again.size(), ev.batch_threads, [&](std::size_t j) { attempt(again[j]); });
      }
    for (const auto &s : searched)
      o.absorb(s);
    const nlopt_result status = statuses.empty() ? NLOPT_SUCCESS : statuses.back();
    c.message = "NLopt status " + std::to_string(static_cast<int>(status));
    const std::vector<double> x = o.best_u; // the best point seen (grid or optimisers)

    c.u           = x;
    c.values      = ev.values(x);
    c.force_gain  = ev.gain(x);
    c.baseline    = ev.baseline(x);
    c.k           = static_cast<int>(dim);
    c.evaluations = o.evaluations + short_runs;
    c.failed      = o.failures == o.evaluations;
    c.n_train     = o.n;
    c.ssr_train   = o.best * static_cast<double>(o.n);
    const double n     = static_cast<double>(std::max<std::size_t>(o.n, 1));
    const double n_eff = independent_values(ev.runs, o.n);
    const double lnL   = n_eff * std::log(std::max(c.ssr_train, 1e-300) / n);
    c.bic         = lnL + c.k * std::log(n_eff);
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

  std::pair<std::size_t, const SignalResidual *>
  most_remaining(const std::vector<std::vector<SignalResidual>> &remaining)
  {
    std::pair<std::size_t, const SignalResidual *> most{0, nullptr};
    for (std::size_t r = 0; r < remaining.size(); ++r)
      if (!remaining[r].empty() && (!most.second || remaining[r].front().noise_units > most.second->noise_units))
        most = {r, &remaining[r].front()};
    return most;
  }

  std::map<std::string, double> pooled_norms(const std::vector<RunCase> &runs,
                                             const std::vector<Signals> &model, bool swings)
  {
    std::map<std::string, double> sum;
    std::map<std::string, int>    count;
    for (std::size_t r = 0; r < runs.size(); ++r)
      for (const auto &[name, v] :
           residual_norms(runs[r].run, model[r], swings ? runs[r].swings : runs[r].scales, runs[r].n_skip))
        {
          sum[name] += v * v;
          ++count[name];
        }
    for (auto &[name, v] : sum)
      v = std::sqrt(v / count[name]);
    return sum;
  }
} // namespace rectify::diagnosis
