#include "diagnosis/named_refit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "diagnosis/fit.h"
#include "diagnosis/identifiability.h"
#include "diagnosis/profiles.h"

namespace rectify::diagnosis
{
  namespace
  {
    /// A partner the record cannot tell from the effect, held at the case's
    /// value (NamedRefit::hold_partner): where it sits, the effect's values
    /// over the partner's range, what became of the refit.
    struct HeldPartner
    {
      std::size_t           j = 0;      ///< its index in base.uncertain
      std::size_t           k = 0;      ///< its index in the free set
      std::string           name;       ///< "table.key"
      double                case_value = 0, split_value = 0;
      std::optional<double> from;       ///< the effect's position that keeps the sum, the partner at the case's
      std::optional<double> range_lo, range_hi; ///< the same at the ends of the partner's range
    };

    class NamedRefit
    {
    public:
      NamedRefit(Context &x, RoundResult &rr, const CandidateResult &named, Evaluator ev, bool left_out_tried)
        : x_(x)
        , rr_(rr)
        , effect_(named.effect)
        , u_(named.u)
        , ev_(std::move(ev))
        , left_out_tried_(left_out_tried)
      {}

      void run()
      {
        if (x_.options.refine_passes > 0)
          free_and_start_again();
        if (left_out_tried_)
          rr_.left_out = rr_.near_miss.at_effect; // what its try did with them
        const double left = refine(rr_.freed, "");
        if (x_.options.refine_passes > 0 && left > 1.0)
          free_shape(left);
        try
          {
            profile();
            hold_partner();
          }
        catch (const std::exception &e)
          {
            rr_.uncertainty_error = e.what();
          }
      }

    private:
      void                  free_and_start_again();
      double                refine(const std::vector<BaselineParameter> &placed, const char *what);
      double                moved_by(const CandidateResult &r) const;
      void                  free_shape(double left);
      void                  profile();
      void                  hold_partner();
      std::optional<double> keeping_sum(const Evaluator &held, const std::vector<double> &uh, std::size_t j,
                                        double w) const;
      void                  refit_held(const Evaluator &held_ev, const std::vector<double> &uh, const HeldPartner &p,
                                       nlohmann::json &h);

      Context            &x_;
      RoundResult        &rr_;
      const std::string   effect_;
      std::vector<double> u_;
      Evaluator           ev_;
      bool                left_out_tried_;
    };

    /// The baseline parameters the named fit determines, freed; the start
    /// chosen again with the named model (the first choice was made with
    /// the case's baseline, which a strong effect leaves so far off that
    /// every start scored alike); the settling window from the named
    /// model's memory of its start (only here: near the noise the start's
    /// error is as large as what is left and biases the value, while the
    /// candidates are compared far above it).
    void NamedRefit::free_and_start_again()
    {
      const auto &options = x_.options;
      auto       &runs    = x_.runs;
      int         checks  = 0;
      rr_.freed           = free_determined(ev_, u_, options.identifiability_sd, checks, x_.cores);
      if (options.start == "auto")
        {
          std::vector<StartState> was;
          for (const auto &rc : runs)
            was.push_back(rc.start);
          choose_start(ev_.parameters(u_), x_.map, runs, options, x_.cores);
          for (std::size_t r = 0; r < runs.size(); ++r)
            if (runs[r].start != was[r]) // a later round appends its own
              runs[r].start_revisions.push_back({was[r], runs[r].start, effect_});
        }
      settle(ev_.parameters(u_), x_.map, runs, options, x_.cores);
    }

    /// The refits until the parameters settle, the first from `placed`
    /// (just freed) placed along their ranges; once settled, the
    /// parameters the case leaves out tried on with the effect in the model
    /// (one turned on: one more refit, with the noise scales at the new
    /// fit). Returns the last refit's training RMS (noise units), or -1 if
    /// none ran.
    double NamedRefit::refine(const std::vector<BaselineParameter> &placed, const char *what)
    {
      const auto &options = x_.options;
      double      last    = -1;
      for (int pass = 0, passes = options.refine_passes; pass < passes; ++pass)
        {
          Evaluator ev = ev_;
          calibrate_noise(ev.parameters(u_), x_.map, x_.runs, options.relative_tolerance, x_.cores);
          if (pass == 0)
            place_freed(ev, placed, u_, x_.cores);
          std::vector<Signals> refined;
          auto                 r = fit(ev, refined, &u_, pass == 0 && !placed.empty() ? 0.05 : 0.02);
          if (r.failed)
            break;
          last = r.rms_train;
          x_.say("%s refitted (%spass %d), noise scales from the model as fitted: BIC %.6g, %d runs, %.1f s",
                 effect_.c_str(), what, pass + 1, r.bic, r.evaluations, r.wall_time_s);
          const double moved     = moved_by(r);
          bool         turned_on = false;
          if ((moved < 0.01 || pass + 1 == passes) && !left_out_tried_)
            {
              left_out_tried_        = true;
              const auto free_before = ev_.free.size();
              const auto tried_at    = Clock::now();
              rr_.left_out           = calibrate_left_out(ev_, r, refined, x_.cores);
              turned_on              = ev_.free.size() > free_before;
              for (const auto &b : rr_.left_out)
                x_.say("%s: %s, %.1f s", b.name.c_str(), standing_words(b).c_str(), seconds_since(tried_at));
            }
          u_             = r.u;
          rr_.values     = r.values;
          rr_.force_gain = r.force_gain;
          rr_.baseline   = r.baseline;
          x_.current     = refined;
          ++rr_.refine_passes;
          if (turned_on)
            {
              ++passes;
              continue;
            }
          if (moved < 0.01)
            break;
        }
      return last;
    }

    /// How far a refit moved the fit (the largest relative change): the
    /// gain, the effect's parameters, and every [uncertain] parameter, not
    /// only the freed ones (one that moves leaves the scales of the model
    /// before it).
    double NamedRefit::moved_by(const CandidateResult &r) const
    {
      double moved = std::abs(r.force_gain / rr_.force_gain - 1.0);
      for (std::size_t j = 0; j < r.values.size(); ++j)
        moved = std::max(moved, std::abs(r.values[j] / rr_.values[j] - 1.0));
      for (const auto &[name, value] : r.baseline)
        if (const auto was = rr_.baseline.find(name); was != rr_.baseline.end() && was->second != 0.0)
          moved = std::max(moved, std::abs(value / was->second - 1.0));
      return moved;
    }

    /// The named effect's own shape (the friction's Stribeck rise):
    /// parameters that do nothing in the case's model and act with the
    /// effect, freed where the data determine them, only where the settled
    /// fit still leaves `left` > 1 noise unit (else its plain form explains
    /// the rest).
    void NamedRefit::free_shape(double left)
    {
      int  checks = 0;
      auto shape  = free_determined(ev_, u_, x_.options.identifiability_sd, checks, x_.cores, true);
      for (const auto &b : shape)
        x_.say("%s: freed with %s (its shape; the settled fit left %.3g noise units)", b.name.c_str(), effect_.c_str(),
               left);
      if (shape.empty())
        return;
      refine(shape, "with its shape, ");
      rr_.freed.insert(rr_.freed.end(), shape.begin(), shape.end());
    }

    /// The parameters' standard errors and profiles; a side of a profile
    /// that fits clearly better than the fit (the valley curves: the fit
    /// stopped in a side basin) becomes the fit, refitted from there and
    /// profiled again, at most max_profile_moves times (each move kept in
    /// the round's profile_moves).
    void NamedRefit::profile()
    {
      for (int move = 0;; ++move)
        {
          int                       runs_here = 0;
          const auto                began     = Clock::now();
          std::optional<BetterSide> better;
          effect_uncertainty(ev_, u_, x_.cores, rr_, runs_here, move < x_.options.max_profile_moves ? &better : nullptr);
          x_.say("%s's standard errors and profiles: %d runs, %.1f s", effect_.c_str(), runs_here,
                 seconds_since(began));
          if (!better)
            break;
          x_.say("%s: its profile fits better at %.4g (training residual %.4g noise units, evidence "
                 "%.1f): refitted from there",
                 effect_.c_str(), better->value, better->rms, better->evidence);
          const auto u_was    = u_;
          const auto held_was = ev_.held;
          u_[better->effect_index] = better->effect_unit;
          ev_.held                 = better->w;
          for (std::size_t i = 0; i < ev_.free.size(); ++i)
            u_[ev_.n_effect() + i] = better->w[ev_.free[i]];
          u_.back() = better->gain_unit;
          if (refine({}, "from its profile, ") < 0)
            { // no refit ran there: the fit stays where it was
              u_       = u_was;
              ev_.held = held_was;
              break;
            }
          rr_.profile_moves.push_back(
            {{"value", better->value}, {"training_residual", better->rms}, {"evidence", better->evidence}});
        }
    }

    /// A parameter the record does not determine, whose combined quantity
    /// it does (a seal and the oil column: the record tells their sum),
    /// lies anywhere along a valley, and the fit's own split is where its
    /// search stopped. Held, not traded: the baseline parameter it trades
    /// with is held at the case's value and the effect refitted, kept where
    /// that fits as well as the split (evidence within the naming's
    /// threshold); the effect's values over that parameter's declared range
    /// are reported beside it.
    void NamedRefit::hold_partner()
    {
      const auto *comb = ev_.effect ? ev_.effect->combination() : nullptr;
      if (!(comb && rr_.combined && rr_.combined->determined && rr_.uncertainty.size() == 1 &&
            !rr_.uncertainty.front().determined))
        return;
      const auto &unc = ev_.base.uncertain;
      HeldPartner p;
      p.name = rr_.uncertainty.front().correlated_with;
      p.j    = unc.size();
      for (std::size_t q = 0; q < unc.size(); ++q)
        if (unc[q].name() == p.name)
          p.j = q;
      const auto at = std::find(ev_.free.begin(), ev_.free.end(), p.j);
      if (p.j == unc.size() || at == ev_.free.end())
        return;
      p.k                  = static_cast<std::size_t>(at - ev_.free.begin());
      const std::size_t ne = ev_.n_effect();
      // only a partner that enters the combined quantity splits it (one the
      // effect trades with otherwise is no part of the sum)
      const auto at_unit = [&](double x) {
        auto v    = u_;
        v[ne + p.k] = x;
        return comb->value(ev_.parameters(v));
      };
      if (!(std::abs(at_unit(1.0) - at_unit(0.0)) > 1e-6 * std::abs(rr_.combined->value)))
        return;
      const auto &q      = unc[p.j];
      const auto &spec   = ev_.effect->parameters().front();
      p.case_value       = ev_.base.real_value(q.table, q.key);
      p.split_value      = uncertain_from_unit(q, u_[ne + p.k]);
      Evaluator held_ev  = ev_;
      held_ev.held[p.j]  = uncertain_to_unit(q, p.case_value);
      held_ev.free.erase(held_ev.free.begin() + static_cast<std::ptrdiff_t>(p.k));
      held_ev.nuisance_start.erase(held_ev.nuisance_start.begin() + static_cast<std::ptrdiff_t>(p.k));
      auto uh = u_;
      uh.erase(uh.begin() + static_cast<std::ptrdiff_t>(ne + p.k));
      p.from = keeping_sum(held_ev, uh, p.j, held_ev.held[p.j]);
      // over the partner's range: where the effect is needed least and most
      // (none: the partner alone holds the sum there)
      p.range_lo = keeping_sum(held_ev, uh, p.j, 1.0);
      p.range_hi = keeping_sum(held_ev, uh, p.j, 0.0);
      if (p.range_lo && p.range_hi && *p.range_lo > *p.range_hi)
        std::swap(p.range_lo, p.range_hi);
      nlohmann::json h = {
        {"parameter", p.name},
        {"case_value", p.case_value},
        {"split", {{p.name, p.split_value}, {spec.key, rr_.values.front()}}},
        {"effect_over_its_range",
         {p.range_lo ? nlohmann::json(spec.from_unit(*p.range_lo)) : nlohmann::json(nullptr),
          p.range_hi ? nlohmann::json(spec.from_unit(*p.range_hi)) : nlohmann::json(nullptr)}},
        {"range", {q.lower, q.upper}},
        {"kept", false}};
      if (p.from)
        refit_held(held_ev, uh, p, h);
      rr_.held_partner = h;
    }

    /// The effect's position that keeps the combined quantity at the fit's
    /// with the partner (index j) at position `w`; none where no value in
    /// the effect's range does (bisection over [0, 1]).
    std::optional<double> NamedRefit::keeping_sum(const Evaluator &held, const std::vector<double> &uh, std::size_t j,
                                                  double w) const
    {
      const auto  *comb   = ev_.effect->combination();
      const double target = rr_.combined->value;
      Evaluator    e      = held;
      e.held[j]           = w;
      auto       x        = uh;
      const auto f        = [&](double y) {
        x[0] = y;
        return comb->value(e.parameters(x)) - target;
      };
      double lo = 0, hi = 1, flo = f(lo);
      if (!(flo * f(hi) <= 0))
        return std::nullopt;
      for (int it = 0; it < 60; ++it)
        {
          const double mid = 0.5 * (lo + hi), fm = f(mid);
          if ((fm <= 0) == (flo <= 0))
            {
              lo  = mid;
              flo = fm;
            }
          else
            hi = mid;
        }
      return 0.5 * (lo + hi);
    }

    /// The effect refitted with the partner held at the case's value, from
    /// the position that keeps the sum; kept where it fits as well as the
    /// split (both in the scales the refit left), else the split restored.
    void NamedRefit::refit_held(const Evaluator &held_ev, const std::vector<double> &uh, const HeldPartner &p,
                                nlohmann::json &h)
    {
      const auto       &spec        = ev_.effect->parameters().front();
      const auto        began       = Clock::now();
      const RoundResult rr_was      = rr_;
      const auto        u_was       = u_;
      const Evaluator   split_ev    = ev_;
      const auto        current_was = x_.current;
      ev_.free                      = held_ev.free; // (an Evaluator holds references)
      ev_.held                      = held_ev.held;
      ev_.nuisance_start            = held_ev.nuisance_start;
      u_                            = uh;
      u_[0]                         = *p.from;
      char what[200];
      std::snprintf(what, sizeof what, "with %s held at the case's %.4g, ", p.name.c_str(), p.case_value);
      const bool   ran       = refine({}, what) >= 0;
      const auto   held_sum  = ev_.training(u_);
      const auto   split_sum = split_ev.training(u_was);
      const double evidence  = independent_values(x_.runs, held_sum.n) *
                              std::log(std::max(held_sum.sum, 1e-300) / std::max(split_sum.sum, 1e-300));
      h["evidence"] = evidence;
      if (ran) // else the refit failed: nothing held to report
        h["held_value"] = rr_.values.front();
      else
        h["refit_failed"] = true;
      const bool keep = ran && evidence <= x_.options.bic_threshold;
      x_.say("%s with %s held at the case's %.4g: %s = %.4g (the split's %.4g, %s %.4g); "
             "evidence %.1f: %s, %.1f s",
             effect_.c_str(), p.name.c_str(), p.case_value, spec.key.c_str(), rr_.values.front(),
             rr_was.values.front(), p.name.c_str(), p.split_value, evidence, keep ? "kept" : "the split kept",
             seconds_since(began));
      if (keep)
        {
          int        runs_here = 0;
          const auto profiled  = Clock::now();
          effect_uncertainty(ev_, u_, x_.cores, rr_, runs_here);
          x_.say("%s's standard errors and profiles with %s held: %d runs, %.1f s", effect_.c_str(), p.name.c_str(),
                 runs_here, seconds_since(profiled));
        }
      else
        {
          rr_                = rr_was;
          u_                 = u_was;
          ev_.free           = split_ev.free;
          ev_.held           = split_ev.held;
          ev_.nuisance_start = split_ev.nuisance_start;
          x_.current         = current_was;
          calibrate_noise(ev_.parameters(u_), x_.map, x_.runs, x_.options.relative_tolerance, x_.cores);
        }
      h["kept"] = keep;
    }

  } // namespace

  void refine_named(Context &x, RoundResult &rr, const CandidateResult &named, Evaluator ev, bool left_out_tried)
  {
    NamedRefit(x, rr, named, std::move(ev), left_out_tried).run();
  }
} // namespace rectify::diagnosis
