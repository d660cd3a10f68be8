#include "diagnosis/profiles.h"

#include <algorithm>
#include <utility>
#include <limits>
#include <array>
#include <cmath>
#include <cstdio>

#include "diagnosis/fit.h"
#include "diagnosis/identifiability.h"
#include "diagnosis/uncertainty.h"

namespace rectify::diagnosis
{
  /// How well the record determines the named effect's parameters at its
  /// final fit (ev, u), two ways:
  /// - locally: the fit's covariance with every [uncertain] parameter and
  ///   the gain counted as unknown within its range (a uniform prior), and
  ///   with them known; the parameter each trades with most. s2 is the
  ///   residual's variance per independent value of the band (as the
  ///   BIC's count): band-limited samples are correlated, and SSR / n
  ///   would make every standard error too small by sqrt(n / independent
  ///   values).
  /// - by its profile: the parameter moved by determined_sd either way
  ///   (a factor exp(+-sd) when log-scaled) and held there while every
  ///   [uncertain] parameter and the gain are refitted. Determined when
  ///   both sides fit worse by more than the naming's evidence (n_eff
  ///   ln(SSR ratio) > bic_threshold). The local covariance can call a
  ///   flat valley determined: forward differences at the integrator's
  ///   tolerance add information that is not there, and the valley
  ///   curves (a seal traded against the oil column can look determined
  ///   to a few per cent locally while one far from it fits as well).
  /// Also the effect's combined quantity, if it declares one. With
  /// `better`: the side that fits better than the fit by more than the
  /// naming's evidence, if any (a fit stopped in a side basin).
  namespace
  {
    /// A side of a parameter's profile: the parameter moved by the profile's
    /// step and held, every [uncertain] parameter and the gain refitted.
    struct Side
    {
      double              value = 0, rms = 0, evidence = 0;
      bool                moved = false, failed = false;
      int                 runs  = 0;
      std::vector<double> u; ///< the refit's point (every free uncertain one, the gain)
    };

    class EffectUncertainty
    {
    public:
      EffectUncertainty(const Evaluator &ev, const std::vector<double> &u, unsigned threads, int &runs_of_the_model)
        : ev_(ev)
        , u_(u)
        , threads_(threads)
        , runs_(runs_of_the_model)
        , determined_sd_(ev.options.determined_relative_sd)
        , every_(with_every_uncertain(ev, u))
        , all_(every_.first)
        , ua_(every_.second)
        , ne_(static_cast<Eigen::Index>(ev.n_effect()))
      {}

      void run(RoundResult &rr, std::optional<BetterSide> *better)
      {
        local_covariance();
        sides_.resize(2 * static_cast<std::size_t>(ne_));
        parallel_for(sides_.size(), threads_, [&](std::size_t k) { profile_side(k); });
        for (const auto &s : sides_)
          runs_ += s.runs;
        if (better)
          better_side(*better);
        rr.uncertainty_runs = runs_;
        rr.uncertainty.clear();
        for (Eigen::Index i = 0; i < ne_; ++i)
          rr.uncertainty.push_back(parameter(i));
        rr.combined.reset();
        if (ev_.effect->combination())
          rr.combined = combined();
        rr.uncertainty_error.clear();
      }

    private:
      void                 local_covariance();
      void                 profile_side(std::size_t k);
      std::vector<double>  profile_start(const Evaluator &profile, std::size_t i, std::vector<double> from, Side &s) const;
      double               evidence(const CandidateResult &x) const
      {
        return n_eff_ * std::log(std::max(x.ssr_train, 1e-300) / std::max(ssr_, 1e-300));
      }
      void                 better_side(std::optional<BetterSide> &better) const;
      ParameterUncertainty parameter(Eigen::Index i) const;
      CombinedEstimate     combined() const;

      const Evaluator                                 &ev_;
      const std::vector<double>                       &u_;
      const unsigned                                   threads_;
      int                                             &runs_;
      const double                                     determined_sd_;
      const std::pair<Evaluator, std::vector<double>>  every_;
      const Evaluator                                 &all_; ///< every [uncertain] parameter free
      const std::vector<double>                       &ua_;  ///< the fit in all_'s positions
      const Eigen::Index                               ne_;  ///< the effect's parameters
      std::vector<double>                              r0_;
      Eigen::MatrixXd                                  J_, C_, Cc_;
      Eigen::MatrixXd                                  Jb_;     ///< J's columns of the baseline and the gain
      Eigen::LDLT<Eigen::MatrixXd>                     normal_; ///< Jb^T Jb + the prior, factored
      DiagnoseOptions                                  short_search_; ///< a profile's refit: one short search
      double                                           ssr_ = 0, n_eff_ = 1, s2_ = 1, rms_best_ = 0;
      std::vector<std::string>                         names_;
      std::vector<Side>                                sides_;
    };

    /// The fit's covariance with every [uncertain] parameter and the gain
    /// unknown within its range (a uniform prior; C) and known (Cc): the
    /// Jacobian by forward differences, s2 the residual's variance per
    /// independent value of the band.
    void EffectUncertainty::local_covariance()
    {
      r0_ = all_.residual_vector(ua_);
      ++runs_;
      J_ = unit_jacobian(all_, ua_, r0_, runs_, threads_);
      for (double e : r0_)
        ssr_ += e * e;
      n_eff_                  = independent_values(all_.runs, r0_.size());
      s2_                     = std::max(ssr_ / n_eff_, 1e-300);
      const Eigen::MatrixXd F = fit_information(J_, s2_, Eigen::VectorXd::Constant(J_.cols(), uniform_prior_precision));
      C_                      = covariance(F);
      Cc_                     = covariance(F.topLeftCorner(ne_, ne_));
      for (const auto &p : ev_.effect->parameters())
        names_.push_back(p.key);
      for (std::size_t j : all_.free)
        names_.push_back(ev_.base.uncertain[j].name());
      names_.push_back("force_gain");
      rms_best_ = std::sqrt(ssr_ / static_cast<double>(std::max<std::size_t>(r0_.size(), 1)));
      // the profiles' Gauss-Newton step over the baseline and the gain, damped by the ranges' prior
      Jb_               = J_.rightCols(J_.cols() - ne_);
      Eigen::MatrixXd A = Jb_.transpose() * Jb_;
      A.diagonal().array() += uniform_prior_precision * s2_;
      normal_.compute(A);
      short_search_                 = ev_.options;
      short_search_.max_evaluations = 0; // + 10 per free parameter (fit)
    }

    /// Side k of the profiles (parameter k / 2, down then up), all at once.
    /// Each refit starts from the best of where the Jacobian puts the
    /// rest's best for that step (a Gauss-Newton step, damped by the
    /// ranges' prior) and a scan of the parameter it trades with most, and
    /// is one short search; a side still short of 100x the naming's
    /// evidence is searched again in full (the candidates' budget) from the
    /// fit's own point, the path that follows a curved valley. A refit can
    /// only overstate a side's evidence: a side that fits as well is
    /// certain, a determined one's standard error a lower bound.
    void EffectUncertainty::profile_side(std::size_t k)
    {
      const std::size_t i    = k / 2;
      const double      sign = k % 2 ? 1.0 : -1.0;
      const auto       &spec = ev_.effect->parameters()[i];
      const double      v    = spec.from_unit(ua_[i]);
      Side             &s    = sides_[k];
      s.value               = spec.from_unit(spec.to_unit(spec.log_scale ? v * std::exp(sign * determined_sd_)
                                                                           : v + sign * determined_sd_ * std::abs(v)));
      const double step = spec.to_unit(s.value) - ua_[i];
      s.moved           = std::abs(step) > 1e-9; // else at its bound: no side to try
      if (!s.moved || ne_ != 1) // (every effect has one parameter; a second would need its own refit)
        return;
      const auto                              nb = Jb_.cols();
      const Eigen::Map<const Eigen::VectorXd> r0v(r0_.data(), static_cast<Eigen::Index>(r0_.size()));
      system::SystemParameters                fixed = all_.base;
      ev_.effect->apply(std::vector<double>{s.value}, fixed);
      std::vector<double>   from(ua_.begin() + ne_, ua_.end()); // every uncertain one's, the gain's
      const Eigen::VectorXd db = normal_.solve(-Jb_.transpose() * (r0v + J_.col(static_cast<Eigen::Index>(i)) * step));
      for (Eigen::Index j = 0; j < nb; ++j)
        from[static_cast<std::size_t>(j)] = std::clamp(from[static_cast<std::size_t>(j)] + db(j), 0.0, 1.0);
      Evaluator profile{fixed, all_.map, all_.runs, nullptr, short_search_, 1, nullptr, 0.0, 1, all_.free, all_.held,
                        from, all_.superseded};
      from = profile_start(profile, i, from, s);
      std::vector<Signals> unused;
      auto                 r = fit(profile, unused, &from, 0.05, 1);
      s.runs += r.evaluations + 1;
      if (!r.failed && evidence(r) < 100 * ev_.options.bic_threshold)
        {
          const std::vector<double> at_fit(ua_.begin() + ne_, ua_.end());
          const auto more = fit(Evaluator{fixed, all_.map, all_.runs, nullptr, ev_.options, 1, nullptr, 0.0, 1,
                                          all_.free, all_.held, at_fit, all_.superseded},
                                unused, &at_fit, 0.05);
          s.runs += more.evaluations + 1;
          if (!more.failed && more.ssr_train < r.ssr_train)
            r = more;
        }
      s.failed = r.failed;
      if (r.failed)
        return;
      s.rms      = std::sqrt(r.ssr_train / static_cast<double>(std::max<std::size_t>(r.n_train, 1)));
      s.evidence = evidence(r);
      s.u        = r.u;
    }

    /// The valley can curve far from where the Jacobian points, so the
    /// parameter i trades with most is also scanned over its range (8
    /// points, the rest where the fit left them): the refit starts from the
    /// best of these and the Gauss-Newton point `from`.
    std::vector<double> EffectUncertainty::profile_start(const Evaluator &profile, std::size_t i,
                                                         std::vector<double> from, Side &s) const
    {
      Eigen::Index partner = -1;
      double       best_r  = 0;
      for (Eigen::Index j = ne_; j < C_.cols(); ++j)
        {
          const double r = std::abs(C_(static_cast<Eigen::Index>(i), j)) /
                           std::sqrt(std::max(C_(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)) * C_(j, j),
                                              1e-300));
          if (r > best_r)
            {
              best_r  = r;
              partner = j - ne_;
            }
        }
      const auto score = [&](const std::vector<double> &x) { return training_or_worst(profile, x); };
      double     best  = score(from);
      ++s.runs;
      if (partner < 0)
        return from;
      const auto                k = static_cast<std::size_t>(partner);
      const std::vector<double> at_fit(ua_.begin() + ne_, ua_.end());
      auto                      at = from;
      for (int g = 0; g < 8; ++g)
        {
          auto x         = at_fit; // the rest where the fit left them
          x[k]           = (g + 0.5) / 8.0;
          const double v = score(x);
          ++s.runs;
          if (v < best)
            {
              best = v;
              at   = x;
            }
        }
      return at;
    }

    /// The side that fits clearly better (by the naming's evidence), if any.
    void EffectUncertainty::better_side(std::optional<BetterSide> &better) const
    {
      better.reset();
      for (std::size_t k = 0; k < sides_.size(); ++k)
        {
          const Side &s = sides_[k];
          if (!s.moved || s.failed || !(s.evidence < -ev_.options.bic_threshold) ||
              s.u.size() != all_.free.size() + 1 || (better && !(s.evidence < better->evidence)))
            continue;
          BetterSide b;
          b.effect_index = k / 2;
          b.effect_unit  = ev_.effect->parameters()[k / 2].to_unit(s.value);
          b.w            = ev_.uncertain_units(u_);
          for (std::size_t i = 0; i < all_.free.size(); ++i)
            b.w[all_.free[i]] = s.u[i];
          b.gain_unit = s.u.back();
          b.value     = s.value;
          b.rms       = s.rms;
          b.evidence  = s.evidence;
          better      = b;
        }
    }

    /// Parameter i: its local standard errors and strongest correlation,
    /// and its profile's. On a parabola the evidence at a step d is
    /// (d / sd)^2 (the chi-square in units of the residual's variance per
    /// independent value): sd = d / sqrt(evidence) per side; a side that
    /// fits as well (evidence <= 1) says more than d.
    ParameterUncertainty EffectUncertainty::parameter(Eigen::Index i) const
    {
      const auto          &spec = ev_.effect->parameters()[static_cast<std::size_t>(i)];
      const double         ui   = ua_[static_cast<std::size_t>(i)];
      ParameterUncertainty p;
      p.key   = spec.key;
      p.value = spec.from_unit(ui);
      // d(ln value)/du for a log-scaled parameter, d(value)/du / |value| for a linear one
      const double per_unit = spec.log_scale ? std::log(spec.upper / spec.lower)
                                             : (spec.upper - spec.lower) / std::max(std::abs(p.value), 1e-300);
      const double sd_unit  = std::sqrt(std::max(C_(i, i), 0.0));
      p.local_relative_sd                = sd_unit * per_unit;
      p.local_relative_sd_given_baseline = std::sqrt(std::max(Cc_(i, i), 0.0)) * per_unit;
      for (Eigen::Index j = 0; j < C_.cols(); ++j)
        if (j != i)
          {
            const double r = C_(i, j) / std::sqrt(std::max(C_(i, i) * C_(j, j), 1e-300));
            if (std::abs(r) > std::abs(p.correlation))
              {
                p.correlation     = r;
                p.correlated_with = names_[static_cast<std::size_t>(j)];
              }
          }
      p.rms_at_fit      = rms_best_;
      p.profile_step    = determined_sd_;
      p.evidence_needed = ev_.options.bic_threshold;
      bool                  tried = false;
      std::array<double, 2> side_sd{0.0, 0.0};
      const double          inf = std::numeric_limits<double>::infinity();
      for (int side = 0; side < 2; ++side)
        {
          const Side &s  = sides_[2 * static_cast<std::size_t>(i) + static_cast<std::size_t>(side)];
          const bool  ok = s.moved && !s.failed;
          p.profile_value[side]    = s.value;
          p.profile_rms[side]      = ok ? s.rms : std::nan("");
          p.profile_evidence[side] = ok ? s.evidence : std::nan("");
          p.profile_tried[side]    = ok;
          if (!ok)
            continue;
          tried         = true;
          side_sd[side] = s.evidence > 1.0 ? determined_sd_ / std::sqrt(s.evidence) : inf;
          if (!(s.evidence > ev_.options.bic_threshold))
            p.profile_determined = false;
        }
      if (!tried) // at both bounds, or no refit possible: the local estimate alone
        side_sd = {p.local_relative_sd, p.local_relative_sd};
      p.relative_sd = std::max(side_sd[0], side_sd[1]);
      p.determined  = tried ? p.profile_determined : p.relative_sd <= determined_sd_;
      const auto at = [&](double sd, double sign) {
        if (std::isinf(sd)) // unknown beyond the profile's step
          return std::nan("");
        return std::clamp(spec.log_scale ? p.value * std::exp(sign * sd) : p.value * (1 + sign * sd), spec.lower,
                          spec.upper);
      };
      p.lower = at(side_sd[0], -1.0);
      p.upper = at(side_sd[1], +1.0);
      return p;
    }

    /// The effect's combined quantity (Effect::Combination) at the fit and
    /// its local standard error (its gradient in the positions: the
    /// function alone, no runs).
    CombinedEstimate EffectUncertainty::combined() const
    {
      const auto      *combination = ev_.effect->combination();
      CombinedEstimate e;
      e.name    = combination->name;
      e.meaning = combination->meaning;
      e.value   = combination->value(all_.parameters(ua_));
      Eigen::VectorXd g(J_.cols());
      for (std::size_t j = 0; j < ua_.size(); ++j)
        {
          const double h = ua_[j] + 1e-4 <= 1.0 ? 1e-4 : -1e-4;
          auto         x = ua_;
          x[j] += h;
          g(static_cast<Eigen::Index>(j)) = (combination->value(all_.parameters(x)) - e.value) / h;
        }
      e.relative_sd = std::sqrt(std::max(propagated_variance(C_, g), 0.0)) / std::max(std::abs(e.value), 1e-300);
      e.determined  = e.relative_sd <= determined_sd_;
      return e;
    }
  } // namespace

  void effect_uncertainty(const Evaluator &ev, const std::vector<double> &u, unsigned threads, RoundResult &rr,
                          int &runs_of_the_model, std::optional<BetterSide> *better)
  {
    EffectUncertainty(ev, u, threads, runs_of_the_model).run(rr, better);
  }
} // namespace rectify::diagnosis
