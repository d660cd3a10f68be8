#include "diagnosis/ringing_start.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

namespace rectify::diagnosis
{
  namespace
  {
    /// The band where `par` can put a ringing in run rc: what its bounds
    /// allow (ringing_Hz decreases in the value), above 2.5 pumping
    /// frequencies (the periodic response's own harmonics below) and below
    /// 0.4 of the sampling rate.
    std::pair<double, double> ringing_band(const EffectParameter &par, const system::SystemParameters &base,
                                           const RunCase &rc)
    {
      const auto  &t  = rc.run.time_s;
      const double fs = static_cast<double>(t.size() - 1) / (t.back() - t.front());
      return {std::max(2.5 * rc.setup.frequency_Hz, par.ringing_Hz(par.upper, base)),
              std::min(0.4 * fs, par.ringing_Hz(par.lower, base))};
    }

    /// A frequency's pair grids (ringing_start) are run only where its
    /// bases and lines along each parameter come within this factor of the
    /// effect's weak end over 3 cycles: a frequency goes further only where
    /// its grid beats the weak end. Every grid point is set to ring at the
    /// frequency, so the pairs only move the ringing's amplitude, damping
    /// and shape about what the lines already try: they refine a frequency
    /// whose lines beat the weak end and do not turn round one whose lines
    /// do not, while costing most of a frequency's runs. So the lines must
    /// beat the weak end first.
    constexpr double pair_grid_reach = 1.0;
  } // namespace

  /// A start for an effect whose first parameter sets a lightly damped
  /// ringing (EffectParameter::ringing_Hz), or nothing. The residual's
  /// dependence on such a parameter is a comb of basins: over the
  /// training part of a 100 Hz run a basin is about +-1 % of L wide, over
  /// its first 3 cycles +-5 % (the ringing's phase error grows with time).
  /// So: (1) the frequencies of the three largest peaks in the residual
  /// of the outlet (or chamber) pressure of each run, between 2.5 f and
  /// 0.4 of the sampling rate, merged over the runs (within 5 %; those
  /// most runs show first): each is a ringing to match with the
  /// parameter's lowest mode (a line rings at its higher modes too, and
  /// the largest peak is not always the lowest mode); (2) the
  /// ringing depends on the baseline too (a line's oil, from its
  /// uncertain bore, sets its wave speed): along each free [uncertain]
  /// parameter that moves the ringing by more than 5 % over its range,
  /// 9 positions, and over each pair of them a 7 x 7 grid (a line's bore
  /// and the oil column can both be far off; only where the lines come
  /// within pair_grid_reach of the weak end), each with the value that
  /// rings at that frequency there, compared over the first 3 cycles of
  /// each run (the baseline as its fit left it, and at the case's
  /// values), for each frequency of (1) (one whose grid does not beat
  /// the effect's weak end over those cycles goes no further), and from
  /// the two best of them a search along the valley (valley_search: the
  /// grid's steps can miss the baseline's basin); (3) about each
  /// frequency's best,
  /// a scan of +-25 % in 2 % steps over the first 3 cycles, (4) then +-2 %
  /// in 0.5 % steps over the first 6. Returns the best point of (4) of
  /// each frequency that beats the effect's weak end over those 6 cycles,
  /// best first (gain as in the start; the caller refines each: over 6
  /// cycles from rest a line's lowest mode set to ring at its second
  /// mode's peak can score better than the right one), or nothing when
  /// the residual shows no ringing in the parameter's range;
  /// counts its (short) runs of the model into runs_of_the_model; `note`
  /// says what became of each frequency.
  namespace
  {
    /// A ringing frequency the residual shows: the runs' peaks merged.
    struct Cluster
    {
      double f;
      double runs, mean_rank;
    };

    /// (1) The frequencies of the three largest peaks in the residual of
    /// the outlet (or chamber) pressure of each run where `par` can ring,
    /// merged over the runs within 5 % (most runs first, then the larger:
    /// lower mean rank; each cluster's median frequency), at most three.
    std::vector<Cluster> ringing_frequencies(const Evaluator &ev, const EffectParameter &par)
    {
      struct Peak
      {
        double      f;
        std::size_t rank;
      };
      std::vector<Peak> peaks;
      for (std::size_t r = 0; r < ev.runs.size(); ++r)
        {
          const auto       &rc   = ev.runs[r];
          const std::string name = rc.run.has("outlet_pressure_Pa")  ? "outlet_pressure_Pa" :
                                   rc.run.has("chamber_pressure_Pa") ? "chamber_pressure_Pa" : "";
          if (name.empty() || !ev.reference || !(*ev.reference)[r].count(name))
            continue;
          const auto         &data  = rc.run.signal(name);
          const auto         &model = (*ev.reference)[r].at(name);
          std::vector<double> t(rc.n_train), residual(rc.n_train);
          for (std::size_t i = 0; i < rc.n_train; ++i)
            {
              t[i]        = rc.run.time_s[i];
              residual[i] = data[i] - model[i];
            }
          const auto [f_low, f_high] = ringing_band(par, ev.base, rc);
          if (!(f_low < f_high))
            continue;
          const auto found = spectral_peaks(t, residual, f_low, f_high, 3);
          for (std::size_t k = 0; k < found.size(); ++k)
            peaks.push_back({found[k], k});
        }
      std::sort(peaks.begin(), peaks.end(), [](const Peak &a, const Peak &b) { return a.f < b.f; });
      std::vector<Cluster> clusters;
      for (std::size_t a = 0; a < peaks.size();)
        {
          std::size_t b    = a;
          double      rank = 0;
          while (b < peaks.size() && peaks[b].f < 1.05 * peaks[a].f)
            rank += static_cast<double>(peaks[b++].rank);
          const double n = static_cast<double>(b - a);
          clusters.push_back({peaks[a + (b - a) / 2].f, n, rank / n});
          a = b;
        }
      std::stable_sort(clusters.begin(), clusters.end(), [](const Cluster &a, const Cluster &b) {
        return a.runs != b.runs ? a.runs > b.runs : a.mean_rank < b.mean_rank;
      });
      if (clusters.size() > 3)
        clusters.resize(3);
      return clusters;
    }

    /// A frequency's way, for the note.
    struct Tried
    {
      double f;
      double grid;  ///< the grid's best over the weak end's (3 cycles); -1: no value in range rings there
      double lines; ///< the bases' and lines' best over the weak end's where the pair grids were not run, else 0
      double six;   ///< its best after the valley search and scans (6 cycles), or -1
    };

    /// The search for ringing starts (ringing_start's steps 2-4).
    class RingingStart
    {
    public:
      RingingStart(const Evaluator &ev, int &runs_of_the_model)
        : ev_(ev)
        , par_(ev.effect->parameters()[0])
        , runs_(runs_of_the_model)
        , short_ev_(ev)
      {
        short_ev_.horizon_cycles = 3.0;
        bases_                   = {ev.start_point()};
        if (const auto prior = ev.prior_point(); prior != bases_[0])
          bases_.push_back(prior);
      }

      std::vector<std::vector<double>> run(const std::vector<Cluster> &clusters, RingingLog &log)
      {
        weak_end_over_3_cycles();
        for (const auto &cluster : clusters)
          try_frequency(cluster.f);
        weak_end_over_6_cycles();
        std::sort(found_.begin(), found_.end(), [](const Found &a, const Found &b) { return a.value < b.value; });
        std::vector<std::vector<double>> starts;
        for (const auto &f : found_)
          if (f.value < none6_.best)
            starts.push_back(f.u);
        log = what_was_tried();
        return starts;
      }

    private:
      struct Found
      {
        double              value; ///< over the first 6 cycles
        std::vector<double> u;
      };

      std::optional<double> ringing_at(const std::vector<double> &u, double f_peak) const;
      void                  weak_end_over_3_cycles();
      void                  weak_end_over_6_cycles();
      void                  grid_points(double f_peak, std::vector<std::vector<double>> &points,
                                        std::vector<bool> &in_pairs) const;
      void                  try_frequency(double f_peak);
      void                  scan(double horizon, double ratio, int half_width, std::vector<double> &best,
                                 double &value);
      RingingLog            what_was_tried() const;

      const Evaluator                 &ev_;
      const EffectParameter           &par_;
      int                             &runs_;
      Evaluator                        short_ev_; ///< over the first 3 cycles
      std::vector<std::vector<double>> bases_;    ///< the baseline as its fit left it, and at the case's values
      Objective                        none3_{&short_ev_, 0, 0, 0, 1e300, {}};
      std::optional<Evaluator>         six_ev_;
      Objective                        none6_{nullptr, 0, 0, 0, 1e300, {}};
      std::vector<Found>               found_;
      std::vector<Tried>               log_;
    };

    /// The parameter's unit position that rings at f_peak on the model at u
    /// (ringing_Hz decreases in the value), or nothing when out of range.
    std::optional<double> RingingStart::ringing_at(const std::vector<double> &u, double f_peak) const
    {
      const auto p = ev_.parameters(u);
      if (!(par_.ringing_Hz(par_.upper, p) < f_peak && f_peak < par_.ringing_Hz(par_.lower, p)))
        return std::nullopt;
      double a = 0, b = 1;
      for (int i = 0; i < 60; ++i)
        {
          const double mid = 0.5 * (a + b);
          (par_.ringing_Hz(par_.from_unit(mid), p) > f_peak ? a : b) = mid;
        }
      return 0.5 * (a + b);
    }

    /// The effect at its weak end ("no ringing") over the first 3 cycles
    /// from the same bases: a frequency whose grid does not beat it is a
    /// peak of the noise (or of a slow model error), not a ringing the
    /// parameter can match.
    void RingingStart::weak_end_over_3_cycles()
    {
      auto weak = bases_;
      for (auto &b : weak)
        b[0] = 0.0;
      evaluate_points(none3_, weak, ev_.batch_threads);
      runs_ += none3_.evaluations;
    }

    /// A start must beat the effect at its weak end over the same 6 cycles
    /// from the same bases: a peak of the noise's spectrum gives a ringing
    /// that only adds to the residual.
    void RingingStart::weak_end_over_6_cycles()
    {
      six_ev_.emplace(ev_);
      six_ev_->horizon_cycles = 6.0;
      none6_                  = Objective{&*six_ev_, 0, 0, 0, 1e300, {}};
      auto weak               = bases_;
      for (auto &b : weak)
        b[0] = 0.0;
      evaluate_points(none6_, weak, ev_.batch_threads);
      runs_ += none6_.evaluations;
    }

    /// (2) From each base: the value that rings at f_peak there, along each
    /// free [uncertain] parameter that moves the ringing by more than 5 %
    /// over its range 9 positions, over each pair of them a 7 x 7 grid
    /// (in_pairs: evaluated second), each with the value that rings at
    /// f_peak there.
    void RingingStart::grid_points(double f_peak, std::vector<std::vector<double>> &points,
                                   std::vector<bool> &in_pairs) const
    {
      const auto try_point = [&](std::vector<double> u) {
        if (const auto at = ringing_at(u, f_peak))
          {
            u[0] = *at;
            points.push_back(std::move(u));
          }
      };
      for (const auto &b : bases_)
        {
          const auto at = ringing_at(b, f_peak);
          if (!at)
            continue;
          try_point(b);
          std::vector<std::size_t> moving;
          for (std::size_t i = 0; i < ev_.free.size(); ++i)
            {
              const std::size_t j  = ev_.n_effect() + i;
              auto              lo = b, hi = b;
              lo[0] = hi[0] = *at;
              lo[j]         = 0.0;
              hi[j]         = 1.0;
              const double f_lo = par_.ringing_Hz(par_.from_unit(*at), ev_.parameters(lo));
              const double f_hi = par_.ringing_Hz(par_.from_unit(*at), ev_.parameters(hi));
              if (std::abs(std::log(f_hi / f_lo)) > 0.05)
                moving.push_back(j);
            }
          for (std::size_t j : moving)
            for (int g = 0; g < 9; ++g)
              {
                auto u = b;
                u[j]   = (g + 0.5) / 9.0;
                try_point(u);
              }
          in_pairs.resize(points.size(), false);
          for (std::size_t a = 0; a < moving.size(); ++a)
            for (std::size_t c = a + 1; c < moving.size(); ++c)
              for (int g = 0; g < 7; ++g)
                for (int h = 0; h < 7; ++h)
                  {
                    auto u       = b;
                    u[moving[a]] = (g + 0.5) / 7.0;
                    u[moving[c]] = (h + 0.5) / 7.0;
                    try_point(u);
                  }
          in_pairs.resize(points.size(), true);
        }
    }

    /// One frequency: its grid over 3 cycles (the pair grids only where the
    /// bases and lines come within pair_grid_reach of the weak end), and
    /// where it beats the weak end a search along the valley from its two
    /// best points (the grid's steps can miss the baseline's basin), then
    /// (3) a scan of +-25 % in 2 % steps over 3 cycles and (4) +-2 % in
    /// 0.5 % steps over 6.
    void RingingStart::try_frequency(double f_peak)
    {
      Objective                        o3{&short_ev_, 0, 0, 0, 1e300, {}};
      std::vector<std::vector<double>> points;
      std::vector<bool>                in_pairs;
      grid_points(f_peak, points, in_pairs);
      std::vector<double>              values(points.size(), 1e300);
      std::vector<std::vector<double>> stage[2];
      std::vector<std::size_t>         index[2];
      for (std::size_t p = 0; p < points.size(); ++p)
        {
          stage[in_pairs[p] ? 1 : 0].push_back(points[p]);
          index[in_pairs[p] ? 1 : 0].push_back(p);
        }
      Tried tried{f_peak, -1, 0, -1};
      for (int st = 0; st < 2; ++st)
        {
          if (st == 1 && !stage[1].empty() && !(o3.best < pair_grid_reach * none3_.best))
            {
              tried.lines = o3.best / none3_.best;
              break;
            }
          Objective  part{&short_ev_, 0, 0, 0, 1e300, {}};
          const auto v = evaluate_points(part, stage[st], ev_.batch_threads);
          for (std::size_t q = 0; q < v.size(); ++q)
            values[index[st][q]] = v[q];
          o3.absorb(part);
        }
      runs_ += o3.evaluations;
      if (!o3.best_u.empty())
        tried.grid = o3.best / none3_.best;
      log_.push_back(tried);
      if (o3.best_u.empty() || !(o3.best < none3_.best))
        return;
      std::vector<std::size_t> order(points.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](auto a, auto b) { return values[a] < values[b]; });
      std::vector<Objective> local(std::min<std::size_t>(2, order.size()), Objective{&short_ev_, 0, 0, 0, 1e300, {}});
      const auto             at = [this](const std::vector<double> &u, double f) { return ringing_at(u, f); };
      parallel_for(local.size(), ev_.batch_threads,
                   [&](std::size_t k) { valley_search({&local[k], at, f_peak}, points[order[k]], 60); });
      for (const auto &o : local)
        {
          runs_ += o.evaluations;
          o3.absorb(o);
        }
      std::vector<double> best  = o3.best_u;
      double              value = o3.best;
      scan(3.0, 1.02, 12, best, value);
      scan(6.0, 1.005, 4, best, value);
      log_.back().six = value;
      found_.push_back({value, best});
    }

    void RingingStart::scan(double horizon, double ratio, int half_width, std::vector<double> &best, double &value)
    {
      Evaluator s_ev      = ev_;
      s_ev.horizon_cycles = horizon;
      Objective                        o{&s_ev, 0, 0, 0, 1e300, {}};
      const double                     centre = par_.from_unit(best[0]);
      std::vector<std::vector<double>> along;
      for (int k = -half_width; k <= half_width; ++k)
        {
          const double v = centre * std::pow(ratio, k);
          if (v < par_.lower || v > par_.upper)
            continue;
          along.push_back(best);
          along.back()[0] = par_.to_unit(v);
        }
      evaluate_points(o, along, ev_.batch_threads);
      if (!o.best_u.empty())
        {
          best  = o.best_u;
          value = o.best;
        }
      runs_ += o.evaluations;
    }

    /// What became of each frequency, for the report.
    RingingLog RingingStart::what_was_tried() const
    {
      RingingLog log;
      for (const auto &t : log_)
        {
          RingingTry r{t.f, t.grid, t.lines, pair_grid_reach, -1, false};
          if (t.grid >= 0 && !(t.lines > 0) && t.six >= 0)
            {
              r.six   = t.six / none6_.best;
              r.start = t.six < none6_.best;
            }
          log.tries.push_back(r);
        }
      return log;
    }
  } // namespace

  std::vector<std::vector<double>> ringing_start(const Evaluator &ev, int &runs_of_the_model, RingingLog &log)
  {
    log                 = {};
    const auto clusters = ringing_frequencies(ev, ev.effect->parameters()[0]);
    if (clusters.empty())
      {
        log.no_peak = true;
        return {};
      }
    return RingingStart(ev, runs_of_the_model).run(clusters, log);
  }
} // namespace rectify::diagnosis
