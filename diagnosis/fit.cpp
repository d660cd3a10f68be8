#include "diagnosis/fit.h"

#include <chrono>
#include <optional>
#include <stdexcept>

#include "diagnosis/ringing_start.h"

namespace rectify::diagnosis
{
  namespace
  {
    /// One candidate's fit (fit()): its start points, the searches from the
    /// best of them, their restarts, the scores at the best point seen.
    class CandidateFit
    {
    public:
      CandidateFit(const Evaluator &ev, const std::vector<double> *from_point, double first_step, int max_attempts)
        : ev_(ev)
        , from_point_(from_point)
        , first_step_(first_step)
        , max_attempts_(max_attempts)
        , o_{&ev, 0, 0, 0, 1e300, {}}
        , dim_(static_cast<unsigned>(ev.dimension()))
        , grid_points_(ev.effect && ev.effect->parameters()[0].grid_points > 0 ? ev.effect->parameters()[0].grid_points
                                                                                : ev.options.grid_points)
        , ringing_(ev.effect && ev.effect->parameters()[0].ringing_Hz ? &ev.effect->parameters()[0] : nullptr)
      {
        c_.effect = ev.effect ? ev.effect->name() : "none";
      }

      CandidateResult run(std::vector<Signals> &predictions)
      {
        const auto start = Clock::now();
        make_starts();
        std::stable_sort(grid_.begin(), grid_.end(), [](const Start &a, const Start &b) { return a.value < b.value; });
        best_start_ = grid_.front().value;
        valleys_first();
        search_from_the_best();
        skip_restarts_where_far();
        restart();
        score(predictions);
        c_.wall_time_s = seconds_since(start);
        return c_;
      }

    private:
      struct Start
      {
        double              value; ///< the objective there
        std::vector<double> u;
        double              step;                 ///< BOBYQA's first step from there
        bool                from_ringing = false; ///< ringing_start's point: always refined
        int                 line = -1; ///< the grid line (one per base) it lies on, -1: not on a grid
        int                 at   = 0;  ///< its position along that line
      };
      struct Search
      {
        std::vector<double> from;   ///< the best point so far
        double              best_f; ///< its value
        double              step;   ///< the next attempt's first step
        bool                gained; ///< the last attempt gained 1 %
      };

      /// A ringing's basins are narrow: first steps of 0.25 % of the value.
      double fine_step(const std::vector<double> &at) const
      {
        const double v = ringing_->from_unit(at[0]);
        return std::abs(ringing_->to_unit(std::min(ringing_->upper, v * 1.0025)) - at[0]) + 1e-6;
      }
      void add_start(const std::vector<double> &at, double step)
      {
        grid_.push_back({objective(dim_, at.data(), nullptr, &o_), at, step});
      }
      void make_starts();
      void valleys_first();
      void search_from_the_best();
      void attempt(std::size_t k);
      void skip_restarts_where_far();
      void restart();
      void score(std::vector<Signals> &predictions);

      const Evaluator              &ev_;
      const std::vector<double>    *from_point_;
      const double                  first_step_;
      int                           max_attempts_;
      CandidateResult               c_;
      Objective                     o_;
      const unsigned                dim_;
      const int                     grid_points_;
      const EffectParameter        *ringing_;
      int                           short_runs_ = 0; ///< runs of the model over part of the record (ringing_start)
      std::vector<Start>            grid_;
      double                        best_start_ = 0;
      std::vector<Search>           search_;
      std::vector<Objective>        searched_;
      std::vector<nlopt_result>     statuses_;
    };

    /// The start points: `from_point`; or a grid over the effect's first
    /// parameter with the baseline as the baseline fit left it and (if
    /// different) at the case's values (a missing effect can pull the
    /// baseline fit far from where the effect's own fit lies), and the
    /// ringing start's points; or none's start.
    void CandidateFit::make_starts()
    {
      std::vector<double> u = ev_.start_point();
      if (from_point_ && from_point_->size() != dim_)
        throw std::logic_error("diagnose: a fit's start point has " + std::to_string(from_point_->size()) +
                               " coordinates, its candidate " + std::to_string(dim_));
      if (from_point_)
        {
          add_start(*from_point_, ringing_ ? fine_step(*from_point_) : first_step_);
          return;
        }
      if (!ev_.effect)
        {
          add_start(u, 0.5 / grid_points_);
          return;
        }
      std::vector<std::vector<double>> bases{u};
      if (const auto prior = ev_.prior_point(); prior != u)
        bases.push_back(prior);
      for (std::size_t l = 0; l < bases.size(); ++l)
        for (int g = 0; g < grid_points_; ++g)
          {
            auto b = bases[l];
            b[0]   = (g + 0.5) / grid_points_;
            add_start(b, 0.5 / grid_points_);
            grid_.back().line = static_cast<int>(l);
            grid_.back().at   = g;
          }
      if (!ringing_)
        return;
      const auto began = Clock::now();
      for (const auto &r : ringing_start(ev_, short_runs_, c_.ringing.emplace()))
        {
          add_start(r, fine_step(r));
          grid_.back().from_ringing = true;
        }
      c_.ringing_runs   = short_runs_;
      c_.ringing_time_s = seconds_since(began);
    }

    /// The grid's valleys first (each the lowest of its neighbours along its
    /// line), then the other points, each group by its value.
    void CandidateFit::valleys_first()
    {
      std::vector<int>    line, at;
      std::vector<double> value;
      for (const auto &g : grid_)
        {
          line.push_back(g.line);
          at.push_back(g.at);
          value.push_back(g.value);
        }
      const std::vector<bool> valley = grid_valleys(line, at, value);
      std::vector<Start>      ordered;
      for (const bool first : {true, false})
        for (std::size_t i = 0; i < grid_.size(); ++i)
          if (valley[i] == first)
            ordered.push_back(grid_[i]);
      grid_ = std::move(ordered);
    }

    /// BOBYQA from the two best of the grid's valleys (a valve that opens
    /// by a small pressure difference can give the residual several basins,
    /// and two neighbouring points of one valley are one start) and from
    /// the ringing start's points wherever they rank (their basins are
    /// narrow, and a coarse grid point can be lower on a short objective
    /// while lying in another basin). The searches are independent: they
    /// run ev.batch_threads at a time, each with its own tally, folded in
    /// order (the same best point as one after another).
    void CandidateFit::search_from_the_best()
    {
      const std::size_t        starts = std::min<std::size_t>(grid_.size(), ev_.effect ? 2 : 1);
      std::vector<std::size_t> chosen;
      for (std::size_t start_i = 0; start_i < grid_.size(); ++start_i)
        if (start_i < starts || grid_[start_i].from_ringing)
          chosen.push_back(start_i);
      search_.resize(chosen.size());
      for (std::size_t k = 0; k < chosen.size(); ++k)
        search_[k] = {grid_[chosen[k]].u, grid_[chosen[k]].value, grid_[chosen[k]].step, true};
      searched_.assign(chosen.size(), Objective{&ev_, 0, 0, 0, 1e300, {}});
      statuses_.assign(chosen.size(), NLOPT_SUCCESS);
      parallel_for(chosen.size(), ev_.batch_threads, [&](std::size_t k) { attempt(k); });
    }

    void CandidateFit::attempt(std::size_t k)
    {
      Search             &s = search_[k];
      std::vector<double> x = s.from;
      std::vector<double> step(dim_, s.step);
      for (std::size_t j = ev_.n_effect(); j < dim_; ++j) // the nuisance
        step[j] = std::min(0.1, s.step);
      double f     = 0;
      statuses_[k] = minimise_in_unit_box(objective, &searched_[k], x, step, ringing_ ? 2e-5 : 2e-4, 1e-7,
                                          ev_.options.max_evaluations + 10 * static_cast<int>(ev_.free.size()), &f);
      s.step   = ringing_ ? s.step : 0.05;
      s.gained = f < 0.99 * s.best_f;
      if (f < s.best_f)
        {
          s.best_f = f;
          s.from   = x;
        }
    }

    /// A candidate is named only where it closes min_gap_closed of the gap
    /// above the noise that none leaves (naming.h). Restarts are skipped
    /// where both: the first searches closed less than restart_closure x
    /// min_gap_closed, and even two more searches each as good as the
    /// first (f - 1 falling by the same ratio again) would stay short of
    /// min_gap_closed. The candidate's BIC is then that of its first
    /// searches; its search note says so.
    void CandidateFit::skip_restarts_where_far()
    {
      if (!(ev_.effect && !from_point_ && gap_above_noise(ev_.none_objective) > 0 && !search_.empty() &&
            max_attempts_ > 1))
        return;
      double first = 1e300;
      for (const auto &s : search_)
        first = std::min(first, s.best_f);
      const double from      = best_start_;
      const double ratio     = from > 1.0 ? std::clamp((first - 1.0) / (from - 1.0), 0.0, 1.0) : 0.0;
      const double projected = 1.0 + (first - 1.0) * std::pow(ratio, max_attempts_ - 1);
      const double closed    = 1.0 - gap_above_noise(first) / gap_above_noise(ev_.none_objective);
      const double reachable = 1.0 - gap_above_noise(projected) / gap_above_noise(ev_.none_objective);
      const double restart   = restart_closure * ev_.options.min_gap_closed;
      if (!(closed < restart && reachable < ev_.options.min_gap_closed))
        return;
      max_attempts_    = 1;
      c_.not_restarted = SearchStop{closed, reachable, restart, ev_.options.min_gap_closed};
    }

    /// Each search within restart_reach of the best restarted (smaller first
    /// step) from its best point while a restart still gains 1 %: the
    /// objective is slightly rough at the integrator's tolerance, which can
    /// stop a trust region early in a curved valley (effect against force
    /// gain). A search left further behind could not overtake.
    void CandidateFit::restart()
    {
      constexpr double restart_reach = 1.25;
      for (int a = 1; a < max_attempts_; ++a)
        {
          double best = 1e300;
          for (const auto &s : search_)
            best = std::min(best, s.best_f);
          std::vector<std::size_t> again;
          for (std::size_t k = 0; k < search_.size(); ++k)
            if (search_[k].gained && search_[k].best_f <= restart_reach * best)
              again.push_back(k);
          parallel_for(again.size(), ev_.batch_threads, [&](std::size_t j) { attempt(again[j]); });
        }
    }

    /// The best point seen (grid or searches): its parameters, BIC and AIC
    /// (counting the band's independent values), its predictions and
    /// training and held-out residuals.
    void CandidateFit::score(std::vector<Signals> &predictions)
    {
      for (const auto &s : searched_)
        o_.absorb(s);
      const nlopt_result status = statuses_.empty() ? NLOPT_SUCCESS : statuses_.back();
      c_.message                = "NLopt status " + std::to_string(static_cast<int>(status));
      const std::vector<double> x = o_.best_u;
      c_.u                        = x;
      c_.values                   = ev_.values(x);
      c_.force_gain               = ev_.gain(x);
      c_.baseline                 = ev_.baseline(x);
      c_.k                        = static_cast<int>(dim_);
      c_.evaluations              = o_.evaluations + short_runs_;
      c_.failed                   = o_.failures == o_.evaluations;
      c_.n_train                  = o_.n;
      c_.ssr_train                = o_.best * static_cast<double>(o_.n);
      const double n              = static_cast<double>(std::max<std::size_t>(o_.n, 1));
      const double n_eff          = independent_values(ev_.runs, o_.n);
      const double lnL            = n_eff * std::log(std::max(c_.ssr_train, 1e-300) / n);
      c_.bic                      = lnL + c_.k * std::log(n_eff);
      c_.aic                      = lnL + 2.0 * c_.k;
      try
        {
          predictions    = simulate_all(ev_.parameters(x), ev_.map, ev_.runs, ev_.options.relative_tolerance,
                                        ev_.run_threads);
          c_.rms_train   = pooled_rms(ev_.runs, predictions, false);
          c_.rms_heldout = pooled_rms(ev_.runs, predictions, true);
        }
      catch (const std::exception &e)
        {
          c_.failed  = true;
          c_.message = e.what();
        }
    }
  } // namespace

  CandidateResult fit(const Evaluator &ev, std::vector<Signals> &predictions, const std::vector<double> *from_point,
                      double first_step, int max_attempts)
  {
    return CandidateFit(ev, from_point, first_step, max_attempts).run(predictions);
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
