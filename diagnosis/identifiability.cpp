#include "diagnosis/identifiability.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "diagnosis/fit.h"

namespace rectify::diagnosis
{
  /// The residual vector's Jacobian at u0 (residual r0 there) by forward
  /// differences of 0.01 in the [0, 1] positions, `threads` columns at
  /// once (each column's runs one after the other then); a run that fails
  /// gives its column no information (zero).
  Eigen::MatrixXd unit_jacobian(const Evaluator &ev, const std::vector<double> &u0, const std::vector<double> &r0,
                                int &runs_of_the_model, unsigned threads)
  {
    Eigen::MatrixXd J(static_cast<Eigen::Index>(r0.size()), static_cast<Eigen::Index>(u0.size()));
    Evaluator       one = ev;
    if (threads > 1)
      one.run_threads = 1;
    parallel_for(u0.size(), threads, [&](std::size_t j) {
      const double h = u0[j] + 0.01 <= 1.0 ? 0.01 : -0.01;
      auto         u = u0;
      u[j] += h;
      std::vector<double> r;
      try
        {
          r = one.residual_vector(u);
        }
      catch (const std::exception &)
        {
          r = r0;
        }
      for (std::size_t i = 0; i < r0.size(); ++i)
        J(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = (i < r.size() ? r[i] - r0[i] : 0.0) / h;
    });
    runs_of_the_model += static_cast<int>(u0.size());
    return J;
  }

  /// The same fit with every [uncertain] parameter free (but those the
  /// effect supersedes, and those that do nothing in the model at u):
  /// the evaluator and the point (effect's positions, every free
  /// uncertain one's, the gain). One that does nothing in the case's
  /// model but acts with the effect (the friction's shape with friction)
  /// counts only where it is free already, or with `effect_shape`.
  std::pair<Evaluator, std::vector<double>> with_every_uncertain(const Evaluator &ev, const std::vector<double> &u,
                                                                 bool effect_shape)
  {
    const std::size_t ne  = ev.n_effect();
    Evaluator         all = ev;
    all.free.clear();
    const std::vector<double> w = ev.uncertain_units(u);
    const auto                p = ev.parameters(u);
    std::vector<double>       ua(u.begin(), u.begin() + static_cast<std::ptrdiff_t>(ne));
    for (std::size_t j = 0; j < ev.base.uncertain.size(); ++j)
      if (const auto &q = ev.base.uncertain[j];
          !ev.is_superseded(j) && !ev.is_off(j, w) && inert_reason(p, q.table, q.key).empty() &&
          (effect_shape || inert_reason(ev.base, q.table, q.key).empty() ||
           std::find(ev.free.begin(), ev.free.end(), j) != ev.free.end()))
        {
          all.free.push_back(j);
          ua.push_back(w[j]);
        }
    ua.push_back(u.back());
    return {all, ua};
  }

  namespace
  {
    double mean_square(const std::vector<double> &r)
    {
      double sum = 0;
      for (double e : r)
        sum += e * e;
      return std::max(sum / static_cast<double>(std::max<std::size_t>(r.size(), 1)), 1e-300);
    }

    struct Determined
    {
      std::vector<bool>        active; ///< per column: still free
      std::vector<double>      sd;     ///< standard error in the [0, 1] position
      /// strongest correlation (|r| > 0.9, else 0) while it was free, and with which column
      std::vector<double>      correlation;
      std::vector<std::string> correlated_with;

      /// Column j's standing as judged: its correlation and whether held.
      void judged(BaselineParameter &b, std::size_t j) const
      {
        b.correlation       = correlation[j];
        b.correlated_with   = correlated_with[j];
        b.held_undetermined = !active[j];
      }
    };

    /// Which parameters (J's columns, named `names`) the data determine:
    /// standard errors from the Gauss-Newton covariance s2 (J^T J)^-1; while
    /// the largest of a `holdable` column exceeds `limit`, or a holdable
    /// column correlates beyond 0.98 with another, that column (of a pair,
    /// the less certain holdable one) is held and the rest re-checked.
    Determined hold_undetermined(const Eigen::MatrixXd &J, double s2, const std::vector<std::string> &names,
                                 const std::vector<bool> &holdable, double limit)
    {
      const std::size_t m = static_cast<std::size_t>(J.cols());
      Determined        d{std::vector<bool>(m, true), std::vector<double>(m, 0.0), std::vector<double>(m, 0.0),
                   std::vector<std::string>(m)};
      for (;;)
        {
          std::vector<Eigen::Index> cols;
          for (std::size_t j = 0; j < m; ++j)
            if (d.active[j])
              cols.push_back(static_cast<Eigen::Index>(j));
          if (cols.empty())
            break;
          Eigen::MatrixXd Js(J.rows(), static_cast<Eigen::Index>(cols.size()));
          for (std::size_t c = 0; c < cols.size(); ++c)
            Js.col(static_cast<Eigen::Index>(c)) = J.col(cols[c]);
          const Eigen::MatrixXd F = Js.transpose() * Js / s2;
          Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(F);
          Eigen::VectorXd inv = eig.eigenvalues();
          const double    top = std::max(inv.maxCoeff(), 1e-300);
          for (Eigen::Index k = 0; k < inv.size(); ++k)
            inv(k) = inv(k) > 1e-12 * top ? 1.0 / inv(k) : 1e300;
          const Eigen::MatrixXd C = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
          const auto corr = [&](std::size_t c, std::size_t e) {
            const auto k = static_cast<Eigen::Index>(c), l = static_cast<Eigen::Index>(e);
            return C(k, l) / std::sqrt(std::max(C(k, k) * C(l, l), 1e-300));
          };
          std::size_t worst    = m;
          double      worst_sd = -1;
          for (std::size_t c = 0; c < cols.size(); ++c)
            {
              const auto  j = static_cast<std::size_t>(cols[c]);
              d.sd[j]       = std::sqrt(std::max(C(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(c)), 0.0));
              // strongest correlation, for the report
              double      best = 0;
              std::size_t with = 0;
              for (std::size_t e = 0; e < cols.size(); ++e)
                if (e != c && std::abs(corr(c, e)) > std::abs(best))
                  {
                    best = corr(c, e);
                    with = static_cast<std::size_t>(cols[e]);
                  }
              const bool strong    = std::abs(best) > 0.9;
              d.correlation[j]     = strong ? best : 0.0;
              d.correlated_with[j] = strong ? names[with] : std::string();
              if (holdable[j] && d.sd[j] > worst_sd)
                {
                  worst_sd = d.sd[j];
                  worst    = j;
                }
            }
          // a pair the data cannot tell apart (|correlation| > 0.98: only a
          // combination is determined, e.g. the cylinder's area and oil
          // column in a no-flow run) holds the less certain of the two
          if (!(worst_sd > limit))
            for (std::size_t c = 0; c < cols.size() && !(worst_sd > limit); ++c)
              for (std::size_t e = c + 1; e < cols.size(); ++e)
                {
                  const auto jc = static_cast<std::size_t>(cols[c]), je = static_cast<std::size_t>(cols[e]);
                  if (std::abs(corr(c, e)) > 0.98 && (holdable[jc] || holdable[je]))
                    {
                      worst    = !holdable[je] || (holdable[jc] && d.sd[jc] >= d.sd[je]) ? jc : je;
                      worst_sd = 2 * limit; // held below
                      break;
                    }
                }
          if (!(worst_sd > limit) || worst == m)
            break;
          d.active[worst] = false;
        }
      return d;
    }

    /// Where a fit at position `unit` (of the declared range) sits on one
    /// of its ends: the data ask for a value beyond it, which a missing
    /// effect does (a seal's compliance taken by the oil column) as well as
    /// a range declared too narrow. -1 the lower, +1 the upper, else 0.
    int end_of_range(double unit)
    {
      constexpr double at_end = 1e-3; // of the range
      return unit >= 1.0 - at_end ? 1 : unit <= at_end ? -1 : 0;
    }
  } // namespace

  /// An [uncertain] parameter as reported: at position `unit`, its case
  /// value, range and standard error. Where `unit` is a fit's, an end of
  /// the range it sits on is said too; where it is the case's value (held
  /// or just freed: `fitted` false), not.
  BaselineParameter baseline_parameter(const system::SystemParameters &base, const system::UncertainParameter &q,
                                       double unit, double sd_unit, bool identifiable, bool fitted)
  {
    BaselineParameter b;
    b.name         = q.name();
    b.value        = uncertain_from_unit(q, unit);
    b.nominal      = base.real_value(q.table, q.key);
    b.lower        = q.lower;
    b.upper        = q.upper;
    b.sd_unit      = sd_unit;
    b.identifiable = identifiable;
    // off (the case's 0) is not an end the data push against
    b.at_end = b.value != 0.0 && fitted ? end_of_range(unit) : 0;
    return b;
  }

  /// The baseline fit's parameters (free [uncertain] ones and the gain):
  /// which of them the data determine (hold_undetermined, s2 = SSR / n at
  /// the fit). Returns one entry per [uncertain] parameter and the gain;
  /// sets ev.free to the identifiable ones and ev.held / ev.nuisance_start
  /// to the fit.
  std::vector<BaselineParameter> check_identifiability(Evaluator &ev, const CandidateResult &none,
                                                       double limit, int &runs_of_the_model, unsigned threads)
  {
    const auto               &base = ev.base;
    const std::vector<double> u0   = none.u; // [free..., gain]
    const std::size_t         m    = u0.size();
    const std::vector<double> r0   = ev.residual_vector(u0);
    ++runs_of_the_model;
    const Eigen::MatrixXd    J = unit_jacobian(ev, u0, r0, runs_of_the_model, threads);
    std::vector<std::string> names;
    for (std::size_t j = 0; j + 1 < m; ++j)
      names.push_back(base.uncertain[ev.free[j]].name());
    names.push_back("force_gain");
    const Determined d = hold_undetermined(J, mean_square(r0), names, std::vector<bool>(m, true), limit);
    std::vector<BaselineParameter> out;
    std::vector<std::size_t>       still_free;
    std::vector<double>            start;
    for (std::size_t j = 0; j + 1 < m; ++j)
      {
        const std::size_t q_index = ev.free[j];
        const auto       &q       = base.uncertain[q_index];
        auto              b       = baseline_parameter(base, q, u0[j], d.sd[j], d.active[j]);
        d.judged(b, j);
        out.push_back(b);
        // held: at the case's value (the prior), not at this fit, which a
        // missing effect may have pulled anywhere
        ev.held[q_index] = d.active[j] ? u0[j] : uncertain_to_unit(q, b.nominal);
        if (d.active[j])
          {
            still_free.push_back(q_index);
            start.push_back(u0[j]);
          }
      }
    BaselineParameter g;
    g.name         = "force_gain";
    g.value        = ev.gain(u0);
    g.nominal      = 1.0;
    g.lower        = 1.0 - ev.options.gain_range;
    g.upper        = 1.0 + ev.options.gain_range;
    g.sd_unit      = d.sd[m - 1];
    g.identifiable = d.active[m - 1];
    g.at_end       = end_of_range(u0[m - 1]);
    d.judged(g, m - 1);
    out.push_back(g);
    ev.free = still_free;
    start.push_back(u0[m - 1]); // the gain is always fitted: held ones only lose their freedom
    ev.nuisance_start = start;
    return out;
  }


  /// After an effect is named: the held [uncertain] parameters that the
  /// data determine at the named model's fit are freed. The baseline fit
  /// judged them at a model without the effect, whose residual (hundreds
  /// of noise units where the effect is strong) inflates every standard
  /// error (s2 = SSR / n) and whose Jacobian is taken where the missing
  /// effect has pulled the others. Judged again here with the effect's
  /// parameters in the covariance, so that a parameter traded against the
  /// effect stays held. `ev` is the named effect's evaluator, `u` its fit;
  /// both are updated to the wider free set. Returns the freed ones.
  /// Without `effect_shape`, the held parameters of the case's model;
  /// with it, only those that do nothing in the case's model and act
  /// with the effect (its shape: the friction's with piston_friction).
  std::vector<BaselineParameter> free_determined(Evaluator &ev, std::vector<double> &u, double limit,
                                                 int &runs_of_the_model, unsigned threads,
                                                 bool effect_shape)
  {
    const auto       &base = ev.base;
    const std::size_t ne = ev.n_effect(), nq = base.uncertain.size();
    std::vector<bool> was_free(nq, false);
    for (std::size_t j : ev.free)
      was_free[j] = true;
    const std::vector<double> w0 = ev.uncertain_units(u);
    const auto                p0 = ev.parameters(u);
    for (std::size_t j = 0; j < nq; ++j)
      if (ev.is_superseded(j) || ev.is_off(j, w0) ||
          !inert_reason(p0, base.uncertain[j].table, base.uncertain[j].key).empty())
        was_free[j] = true; // not a candidate for freeing (does nothing here)
    // held, and not this call's to free: stays held (its column still counts)
    std::vector<bool> skip(nq, false);
    for (std::size_t j = 0; j < nq; ++j)
      skip[j] = !was_free[j] && inert_reason(base, base.uncertain[j].table, base.uncertain[j].key).empty() == effect_shape;
    bool any = false;
    for (std::size_t j = 0; j < nq; ++j)
      any = any || (!was_free[j] && !skip[j]);
    if (!any)
      return {};
    const auto [all, ua]         = with_every_uncertain(ev, u, effect_shape);
    const std::vector<double> w  = ev.uncertain_units(u);
    const std::vector<double> r0 = all.residual_vector(ua);
    ++runs_of_the_model;
    const Eigen::MatrixXd    J = unit_jacobian(all, ua, r0, runs_of_the_model, threads);
    std::vector<std::string> names;
    std::vector<bool>        holdable;
    for (std::size_t i = 0; i < ne; ++i)
      {
        names.push_back(ev.effect->parameters()[i].key);
        holdable.push_back(false);
      }
    for (std::size_t j : all.free)
      {
        names.push_back(base.uncertain[j].name());
        holdable.push_back(!was_free[j]);
      }
    names.push_back("force_gain");
    holdable.push_back(false);
    const Determined d = hold_undetermined(J, mean_square(r0), names, holdable, limit);

    std::vector<BaselineParameter> freed;
    std::vector<std::size_t>       free;
    std::vector<double>            un(u.begin(), u.begin() + static_cast<std::ptrdiff_t>(ne));
    for (std::size_t c = 0; c < all.free.size(); ++c)
      {
        const std::size_t j = all.free[c], k = ne + c;
        if (!was_free[j] && (!d.active[k] || skip[j]))
          continue;
        free.push_back(j);
        un.push_back(w[j]);
        if (was_free[j])
          continue;
        // where it is freed is the value it was held at, not a fit
        freed.push_back(baseline_parameter(base, base.uncertain[j], w[j], d.sd[k], true, false));
        d.judged(freed.back(), k);
        freed.back().effect_shape = effect_shape;
      }
    un.push_back(u.back());
    ev.free = free;
    u       = un;
    return freed;
  }

  /// The training residual's sum of squares at x, or 1e300 where the
  /// model fails to integrate (a scan point is then simply not chosen).
  double training_or_worst(const Evaluator &ev, const std::vector<double> &x)
  {
    try
      {
        return ev.training(x).sum;
      }
    catch (const std::exception &)
      {
        return 1e300;
      }
  }

  /// The [uncertain] parameters the case leaves out (its value 0, off_at_zero:
  /// the outlet passage's inertance, which the thesis's model has none of),
  /// tried on after a fit without them (the named effect's settled fit),
  /// one at a time. The
  /// residual over such a parameter is a comb of basins (the passage's
  /// ringing sets the phase of each valve event): a trust region from
  /// off does not cross it, one start along the range can end in the
  /// wrong tooth. So the model is refitted from
  /// `left_out_starts` points spread along its range, every one refined
  /// to the end (all at once on `threads`), and the best is kept where
  /// its BIC beats the fit without it (a record without it keeps it off,
  /// as the case has it). Not tried where the named fit's training
  /// residual is within the noise (RMS <= 1 noise unit): nothing is left
  /// for it to explain. Updates ev (the parameter joins the free set
  /// at its fit), `fitted` (the named effect's fit) and its
  /// predictions; returns one entry per parameter, on or off.
  std::vector<BaselineParameter> calibrate_left_out(Evaluator &ev, CandidateResult &fitted,
                                                    std::vector<Signals> &predictions, unsigned threads)
  {
    constexpr int                  left_out_starts = 4;
    std::vector<BaselineParameter> out;
    for (std::size_t j = 0; j < ev.base.uncertain.size(); ++j)
      {
        const auto &q = ev.base.uncertain[j];
        if (!q.off_at_zero || ev.is_superseded(j) || fitted.failed || fitted.u.size() != ev.dimension() ||
            std::find(ev.free.begin(), ev.free.end(), j) != ev.free.end())
          continue;
        if (fitted.rms_train <= 1.0)
          {
            // nothing above the noise left for it to explain: a BIC gain
            // there is the noise's own structure, and its tries would be
            // the longest step of a loaded record
            out.push_back(baseline_parameter(ev.base, q, 0.0, 0.0, false));
            out.back().tried = LeftOutTry{LeftOutTry::Outcome::not_tried, 0, fitted.rms_train};
            continue;
          }
        const auto started = Clock::now();
        Evaluator  with    = ev;
        with.free.push_back(j);
        with.run_threads = 1;
        std::vector<CandidateResult>      tried(left_out_starts);
        std::vector<std::vector<Signals>> made(left_out_starts);
        parallel_for(tried.size(), threads, [&](std::size_t g) {
          std::vector<double> from = fitted.u;
          from.insert(from.end() - 1, (static_cast<double>(g) + 0.5) / left_out_starts);
          tried[g] = fit(with, made[g], &from, 0.05);
        });
        std::size_t best  = 0;
        int         total = 0;
        for (std::size_t g = 0; g < tried.size(); ++g)
          {
            total += tried[g].evaluations;
            if (!tried[g].failed && (tried[best].failed || tried[g].bic < tried[best].bic))
              best = g;
          }
        const double wall = fitted.wall_time_s + seconds_since(started);
        LeftOutTry   how{LeftOutTry::Outcome::failed, left_out_starts, fitted.rms_train,
                       uncertain_from_unit(q, (static_cast<double>(best) + 0.5) / left_out_starts), tried[best].bic,
                       fitted.bic};
        if (!tried[best].failed && tried[best].bic < fitted.bic)
          {
            how.outcome = LeftOutTry::Outcome::on;
            total += fitted.evaluations;
            fitted             = tried[best];
            fitted.evaluations = total;
            fitted.wall_time_s = wall;
            predictions        = made[best];
            ev.free            = with.free;
            ev.held[j]         = fitted.u[fitted.u.size() - 2];
            ev.nuisance_start.assign(fitted.u.begin() + static_cast<std::ptrdiff_t>(ev.n_effect()), fitted.u.end());
            out.push_back(baseline_parameter(ev.base, q, ev.held[j], 0.0, true));
          }
        else
          {
            fitted.evaluations += total;
            fitted.wall_time_s = wall;
            if (!tried[best].failed) // else every start failed to simulate
              how.outcome = LeftOutTry::Outcome::no_better;
            out.push_back(baseline_parameter(ev.base, q, 0.0, 0.0, false));
          }
        out.back().tried = how;
      }
    return out;
  }

  /// A freed parameter starts at the case's value, which can lie far from
  /// its fit, along a valley too rough for a trust region's first steps:
  /// each is placed at the best of a 10-point scan over its range (the
  /// others where they are) before the refit.
  void place_freed(const Evaluator &ev, const std::vector<BaselineParameter> &freed, std::vector<double> &u,
                   unsigned threads)
  {
    Evaluator one = ev;
    if (threads > 1)
      one.run_threads = 1;
    const auto score = [&](const std::vector<double> &x) { return training_or_worst(one, x); };
    for (const auto &b : freed)
      {
        const auto at = std::find_if(ev.free.begin(), ev.free.end(),
                                     [&](std::size_t j) { return ev.base.uncertain[j].name() == b.name; });
        const std::size_t k    = ev.n_effect() + static_cast<std::size_t>(at - ev.free.begin());
        // the 10 points at once, then the first best in order (as one by one)
        std::vector<double> val(11);
        parallel_for(val.size(), threads, [&](std::size_t g) {
          auto x = u;
          if (g > 0)
            x[k] = (static_cast<double>(g) - 0.5) / 10.0;
          val[g] = score(x);
        });
        double best = val[0];
        for (std::size_t g = 1; g < val.size(); ++g)
          if (val[g] < best)
            {
              best = val[g];
              u[k] = (static_cast<double>(g) - 0.5) / 10.0;
            }
      }
  }

} // namespace rectify::diagnosis
