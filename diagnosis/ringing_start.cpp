#include "diagnosis/ringing_start.h"

#include <algorithm>
#include <cmath>
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
    /// and shape about what the lines already try. On the bench's 32
    /// records and the diagnosis benchmark (75 frequencies with both run)
    /// the pair grids took at most 1.94 x off the lines' best and never
    /// turned a frequency round: none whose lines stayed at or above the
    /// weak end had its pair grid beat it (where a hose was there to be
    /// found its lines already beat the weak end 1.5-18 fold, and the pairs
    /// changed that 0.88-1.33 x). So the lines must beat the weak end. A
    /// frequency the pairs cannot turn round costs most of the line's runs:
    /// 588 of 871 in piston_friction-0 (lines 3.9 and 5.3 x above), 588 of
    /// 1356 in the diagnosis benchmark (lines 1.005 and 1.085 x).
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
  std::vector<std::vector<double>> ringing_start(const Evaluator &ev, int &runs_of_the_model, std::string &note)
  {
    note.clear();
    const EffectParameter &par = ev.effect->parameters()[0];
    struct Peak
    {
      double      f;
      std::size_t rank;
    };
    std::vector<Peak> peaks;
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
        const auto [f_low, f_high] = ringing_band(par, ev.base, rc);
        if (!(f_low < f_high))
          continue;
        const auto found = spectral_peaks(t, residual, f_low, f_high, 3);
        for (std::size_t k = 0; k < found.size(); ++k)
          peaks.push_back({found[k], k});
      }
    if (peaks.empty())
      {
        note = "no peak in the residual's spectrum where it can ring";
        return {};
      }
    // merge the runs' peaks within 5 %: most runs first, then the larger
    // (lower mean rank); each cluster's median frequency
    std::sort(peaks.begin(), peaks.end(), [](const Peak &a, const Peak &b) { return a.f < b.f; });
    struct Cluster
    {
      double f;
      double runs, mean_rank;
    };
    std::vector<Cluster> clusters;
    for (std::size_t a = 0; a < peaks.size();)
      {
        std::size_t b = a;
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

    // the parameter's unit position that rings at f_peak on the model at u
    // (ringing_Hz decreases in the value), or nothing when out of range
    const auto ringing_at = [&](const std::vector<double> &u, double f_peak) -> std::optional<double> {
      const auto p = ev.parameters(u);
      if (!(par.ringing_Hz(par.upper, p) < f_peak && f_peak < par.ringing_Hz(par.lower, p)))
        return std::nullopt;
      double a = 0, b = 1;
      for (int i = 0; i < 60; ++i)
        {
          const double mid = 0.5 * (a + b);
          (par.ringing_Hz(par.from_unit(mid), p) > f_peak ? a : b) = mid;
        }
      return 0.5 * (a + b);
    };

    Evaluator short_ev = ev;
    short_ev.horizon_cycles = 3.0;
    std::vector<std::vector<double>> bases{ev.start_point()};
    if (const auto prior = ev.prior_point(); prior != bases[0])
      bases.push_back(prior);
    struct Found
    {
      double              value; ///< over the first 6 cycles
      std::vector<double> u;
    };
    std::vector<Found> found;
    struct Tried // a frequency's way, for the note
    {
      double f;
      double grid;  ///< the grid's best over the weak end's (3 cycles); -1: no value in range rings there
      double lines; ///< the bases' and lines' best over the weak end's where the pair grids were not run, else 0
      double six;   ///< its best after the valley search and scans (6 cycles), or -1
    };
    std::vector<Tried> log;
    // the effect at its weak end ("no ringing") over the same 3 cycles
    // from the same bases: a frequency whose grid does not beat it is a
    // peak of the noise (or of a slow model error), not a ringing the
    // parameter can match. On the bench a real line's grid beat it 4-17
    // fold, a noise peak's lost 5-9000 fold, and the valley search and
    // scans after it (about half of the frequency's runs) never turned
    // that round.
    Objective none3{&short_ev, 0, 0, 0, 1e300, {}};
    {
      auto weak = bases;
      for (auto &b : weak)
        b[0] = 0.0;
      evaluate_points(none3, weak, ev.batch_threads);
      runs_of_the_model += none3.evaluations;
    }
    for (const auto &cluster : clusters)
      {
        const double f_peak = cluster.f;
        Objective                        o3{&short_ev, 0, 0, 0, 1e300, {}};
        std::vector<std::vector<double>> points; // evaluated together below
        const auto                       try_point = [&](std::vector<double> u) {
          if (const auto at = ringing_at(u, f_peak))
            {
              u[0] = *at;
              points.push_back(std::move(u));
            }
        };
        std::vector<bool> in_pairs; // per point: of a pair grid (evaluated second)
        const auto valley = [&](const std::vector<double> &b) {
          const auto at = ringing_at(b, f_peak); // the value that rings at f_peak here
          if (!at)
            return;
          try_point(b);
          // the baseline parameters that move that ringing
          std::vector<std::size_t> moving;
          for (std::size_t i = 0; i < ev.free.size(); ++i)
            {
              const std::size_t j = ev.n_effect() + i;
              auto lo = b, hi = b;
              lo[0] = hi[0] = *at;
              lo[j] = 0.0;
              hi[j] = 1.0;
              const double f_lo = par.ringing_Hz(par.from_unit(*at), ev.parameters(lo));
              const double f_hi = par.ringing_Hz(par.from_unit(*at), ev.parameters(hi));
              if (std::abs(std::log(f_hi / f_lo)) > 0.05)
                moving.push_back(j);
            }
          // along each, 9 positions; over each pair, 7 x 7 (a line's bore
          // and the oil column can both be far off)
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
                    auto u        = b;
                    u[moving[a]] = (g + 0.5) / 7.0;
                    u[moving[c]] = (h + 0.5) / 7.0;
                    try_point(u);
                  }
          in_pairs.resize(points.size(), true);
        };
        for (const auto &b : bases)
          valley(b);
        // the bases and the lines along each parameter first; the pair
        // grids only where those come within pair_grid_reach of the weak
        // end (the same points in the same order as all at once)
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
            if (st == 1 && !stage[1].empty() && !(o3.best < pair_grid_reach * none3.best))
              {
                tried.lines = o3.best / none3.best;
                break;
              }
            Objective  part{&short_ev, 0, 0, 0, 1e300, {}};
            const auto v = evaluate_points(part, stage[st], ev.batch_threads);
            for (std::size_t q = 0; q < v.size(); ++q)
              values[index[st][q]] = v[q];
            o3.absorb(part);
          }
        runs_of_the_model += o3.evaluations;
        if (!o3.best_u.empty())
          tried.grid = o3.best / none3.best;
        log.push_back(tried);
        if (o3.best_u.empty() || !(o3.best < none3.best))
          continue;
        // (2b) from the grid's two best points, a search along the valley
        // (the grid's steps are a factor 1.8 in a 60-fold range: the
        // line's oil column can sit between them), both at once
        std::vector<std::size_t> order(points.size());
        std::iota(order.begin(), order.end(), 0);
        std::sort(order.begin(), order.end(), [&](auto a, auto b) { return values[a] < values[b]; });
        std::vector<Objective> local(std::min<std::size_t>(2, order.size()),
                                     Objective{&short_ev, 0, 0, 0, 1e300, {}});
        parallel_for(local.size(), ev.batch_threads, [&](std::size_t k) {
          valley_search({&local[k], ringing_at, f_peak}, points[order[k]], 60);
        });
        for (const auto &o : local)
          {
            runs_of_the_model += o.evaluations;
            o3.absorb(o);
          }
        std::vector<double> best  = o3.best_u;
        double              value = o3.best;

        const auto scan = [&](double horizon, double ratio, int half_width) {
          Evaluator s_ev      = ev;
          s_ev.horizon_cycles = horizon;
          Objective    o{&s_ev, 0, 0, 0, 1e300, {}};
          const double centre = par.from_unit(best[0]);
          std::vector<std::vector<double>> along;
          for (int k = -half_width; k <= half_width; ++k)
            {
              const double v = centre * std::pow(ratio, k);
              if (v < par.lower || v > par.upper)
                continue;
              along.push_back(best);
              along.back()[0] = par.to_unit(v);
            }
          evaluate_points(o, along, ev.batch_threads);
          if (!o.best_u.empty())
            {
              best  = o.best_u;
              value = o.best;
            }
          runs_of_the_model += o.evaluations;
        };
        scan(3.0, 1.02, 12);
        scan(6.0, 1.005, 4);
        log.back().six = value;
        found.push_back({value, best});
      }
    // a start must beat the effect at its weak end ("no effect") over
    // the same 6 cycles from the same bases: a peak of the noise's
    // spectrum gives a ringing that only adds to the residual, and its
    // refinement would cost hundreds of runs for nothing
    Evaluator six_ev      = ev;
    six_ev.horizon_cycles = 6.0;
    Objective none6{&six_ev, 0, 0, 0, 1e300, {}};
    for (auto &b : bases)
      b[0] = 0.0;
    evaluate_points(none6, bases, ev.batch_threads);
    runs_of_the_model += none6.evaluations;
    std::sort(found.begin(), found.end(), [](const Found &a, const Found &b) { return a.value < b.value; });
    std::vector<std::vector<double>> starts;
    for (const auto &f : found)
      if (f.value < none6.best)
        starts.push_back(f.u);
    // what became of each frequency, for the report
    for (const auto &t : log)
      {
        char buf[240];
        if (t.grid < 0)
          std::snprintf(buf, sizeof buf, "%.0f Hz: out of its range", t.f);
        else if (t.lines > 0)
          std::snprintf(buf, sizeof buf,
                        "%.0f Hz: the lines along the baseline %.3g x the residual with it off over 3 cycles, its "
                        "pair grids not run (below %.3g x needed)",
                        t.f, t.lines, pair_grid_reach);
        else if (t.six < 0)
          std::snprintf(buf, sizeof buf, "%.0f Hz: its grid %.3g x the residual with it off over 3 cycles, no further",
                        t.f, t.grid);
        else
          std::snprintf(buf, sizeof buf,
                        "%.0f Hz: its grid %.3g x the residual with it off over 3 cycles, refined to %.3g x over 6 (%s)",
                        t.f, t.grid, t.six / none6.best, t.six < none6.best ? "a start" : "not a start");
        note += (note.empty() ? "" : "; ") + std::string(buf);
      }
    return starts;
  }
} // namespace rectify::diagnosis
