// The diagnosis workflow (diagnose.h): the stages in their order. Each round
// fits the baseline ("none") and every candidate, judges them by the naming
// rules (naming.h), and refines the named effect's fit; the verdict follows
// the last round.
#include "diagnosis/diagnose.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>

#include "diagnosis/context.h"
#include "diagnosis/fit.h"
#include "diagnosis/identifiability.h"
#include "diagnosis/naming.h"
#include "diagnosis/named_refit.h"
#include "diagnosis/search.h"
#include "diagnosis/sensors.h"
#include "diagnosis/verdict.h"
#include "diagnosis/words.h"

namespace rectify::diagnosis
{
  namespace
  {
    /// The cores a search may find idle (minimise_in_unit_box), for one diagnosis.
    struct LendCores
    {
      explicit LendCores(unsigned n)
      {
        core_use().cores       = static_cast<int>(n);
        core_use().computing   = 1;
        core_use().handed_over = 0;
      }
      ~LendCores() { core_use().cores = 0; }
    };

    FitScores scores(const CandidateResult &c) { return {c.effect, c.bic, c.rms_train, c.rms_heldout}; }

    /// One round: the baseline and every candidate fitted, judged, the named
    /// one refined (named_refit.h).
    class Round
    {
    public:
      Round(Context &x, int index)
        : x_(x)
        , index_(index)
      {}

      RoundResult run()
      {
        list_candidates();
        fit_baseline();
        fit_candidates();
        rank_by_bic();
        refit_none_from_best();
        judge_candidates();
        for (auto &c : fitted_)
          rr_.candidates.push_back(c);
        if (index_ == 0)
          x_.baseline_prediction = predictions_[0];
        return rr_;
      }

    private:
      /// none's fit with the parameters the case leaves out tried on, made
      /// once where first needed (calibrate_left_out)
      struct NoneTried
      {
        Evaluator                      ev;
        CandidateResult                fit;
        std::vector<Signals>           made;
        std::vector<BaselineParameter> left;
        bool                           on = false; ///< one of them turned on
      };

      void                            list_candidates();
      void                            fit_baseline();
      std::vector<BaselineParameter>  left_off_parameters() const;
      void                            fit_candidates();
      void                            fit_candidate(std::size_t i);
      void                            rank_by_bic();
      void                            refit_none_from_best();
      void                            judge_candidates();
      bool                            judge_in_order(int look);
      bool                            judge_nearest_miss_again();
      void                            end_judging(int look);
      Judgement                       judge_one(std::size_t i, const CandidateResult &base,
                                                const std::vector<Signals> &base_made) const;
      NamingRules rules() const { return {x_.options.bic_threshold, x_.options.min_gap_closed}; }
      FeatureScores                   dominant_feature(const std::vector<Signals> &base_made,
                                                       const std::vector<Signals> &made) const;
      bool                            sets_left_out(const Effect *e) const;
      const NoneTried                &none_tried();
      void                            name(std::size_t i, const Judgement &j);

      Context    &x_;
      const int   index_;
      RoundResult rr_;
      std::vector<const Effect *>       todo_{nullptr}; ///< none first, then the candidates
      std::vector<CandidateResult>      fitted_;
      std::vector<std::vector<Signals>> predictions_;
      std::optional<Evaluator>          baseline_ev_;
      std::vector<BaselineParameter>    left_off_; ///< the parameters the baseline holds off
      std::vector<std::size_t>          order_;    ///< the candidates by BIC
      /// Judged twice at most: the second time only the nearest miss, with
      /// the parameters the case leaves out tried on at none's fit and at its own
      std::vector<std::size_t>          judged_;
      std::optional<Evaluator>          named_from_; ///< the nearest miss's evaluator, with them
      std::optional<CandidateResult>    saved_none_, saved_near_; ///< the fits without them
      std::vector<std::vector<Signals>> saved_made_;              ///< and their predictions
      std::optional<NoneTried>          none_with_;
      double                            bic_min_ = 1e300, weight_sum_ = 0;
      std::size_t                       nearest_ = 0; ///< the near miss closing the largest share of the gap
      Judgement                         near_judged_; ///< its judgement

    };

    // ---------------------------------------------------------------- Round

    void Round::list_candidates()
    {
      for (const auto &e : x_.library)
        if (std::find(x_.named.begin(), x_.named.end(), e->name()) == x_.named.end())
          {
            const std::string why = e->not_testable(x_.traits);
            if (why.empty())
              todo_.push_back(e.get());
            else
              {
                CandidateResult c;
                c.effect       = e->name();
                c.not_testable = why;
                rr_.candidates.push_back(c);
              }
          }
      fitted_.resize(todo_.size());
      predictions_.resize(todo_.size());
    }

    /// The baseline first: "none" with every [uncertain] parameter and the
    /// force gain; then which of them the data determine (the others are
    /// held at this fit), and every candidate from there. The candidates are
    /// compared on the first training cycles of each run
    /// (DiagnoseOptions::compared_cycles); the named one is refitted on all.
    void Round::fit_baseline()
    {
      const auto &options = x_.options;
      baseline_ev_.emplace(Evaluator::make(x_.base, x_.map, x_.runs, nullptr, options, x_.cores, &x_.current));
      Evaluator &ev     = *baseline_ev_;
      ev.horizon_cycles = screening_cycles_per_run(x_.runs, options.compared_cycles);
      if (index_ == 0)
        x_.result.compared_cycles_per_run = ev.horizon_cycles;
      if (ev.horizon_cycles > 0)
        x_.say("candidates fitted and compared on the first %.3g training cycles of each run after its settling "
               "(at most %.3g in all); the named effect refitted on every training cycle",
               ev.horizon_cycles, options.compared_cycles);
      fitted_[0] = fit(ev, predictions_[0]);
      left_off_  = left_off_parameters();
      int checks = 0;
      if (!fitted_[0].failed && fitted_[0].u.size() == ev.dimension())
        rr_.baseline_check = check_identifiability(ev, fitted_[0], options.identifiability_sd, checks, x_.cores);
      rr_.baseline_check.insert(rr_.baseline_check.end() - (rr_.baseline_check.empty() ? 0 : 1), left_off_.begin(),
                                left_off_.end()); // before the gain, the last
      fitted_[0].evaluations += checks;
      if (ev.free.size() + 1 < fitted_[0].u.size())
        {
          // some held at the case's values: refit none in the same space
          // as the candidates, so that their scores compare like with like
          const int           before = fitted_[0].evaluations;
          std::vector<double> from   = ev.nuisance_start;
          fitted_[0]                 = fit(ev, predictions_[0], &from);
          fitted_[0].evaluations += before;
        }
      x_.report(fitted_[0]);
      if (x_.store)
        x_.store->check_none(index_, fitted_[0]);
    }

    /// The parameters the baseline holds: those the case leaves out stay off
    /// until an effect is named (calibrate_left_out tries them on with it;
    /// tried before naming, the outlet passage takes the gap of other
    /// effects), and those that do nothing in the case's model stay at the
    /// case's value until a named effect makes them act.
    std::vector<BaselineParameter> Round::left_off_parameters() const
    {
      const Evaluator               &ev = *baseline_ev_;
      std::vector<BaselineParameter> out;
      for (std::size_t j = 0; j < ev.base.uncertain.size(); ++j)
        if (const auto &q = ev.base.uncertain[j]; q.off_at_zero && !(ev.base.real_value(q.table, q.key) > 0.0))
          {
            out.push_back(baseline_parameter(ev.base, q, 0.0, 0.0, false));
            out.back().left_out = true;
          }
        else if (const auto why = inert_reason(ev.base, q.table, q.key); !why.empty())
          {
            out.push_back(baseline_parameter(ev.base, q, ev.held[j], 0.0, false, false));
            out.back().inert = why;
          }
      return out;
    }

    /// Every candidate from the baseline's fit, on every core; those with a
    /// ringing search first (the longest fits: hundreds of short runs,
    /// batched) while the others share what is left.
    void Round::fit_candidates()
    {
      std::vector<std::size_t> schedule;
      for (std::size_t i = 1; i < todo_.size(); ++i)
        schedule.push_back(i);
      std::stable_partition(schedule.begin(), schedule.end(), [&](std::size_t i) {
        return todo_[i] && !todo_[i]->parameters().empty() && todo_[i]->parameters()[0].ringing_Hz;
      });
      parallel_for(schedule.size(), x_.cores, [&](std::size_t j) { fit_candidate(schedule[j]); });
      std::sort(x_.result.resumed.begin(), x_.result.resumed.end()); // in no order the cores set
    }

    void Round::fit_candidate(std::size_t i)
    {
      Evaluator ev = *baseline_ev_;
      ev.use_effect(todo_[i]);
      ev.none_objective = fitted_[0].n_train ? fitted_[0].ssr_train / static_cast<double>(fitted_[0].n_train) : 0.0;
      ev.run_threads    = 1;
      ev.reference      = &x_.current;
      ev.batch_threads  = x_.cores;
      if (const auto kept = x_.store ? x_.store->find(index_, todo_[i]->name()) : std::nullopt)
        {
          // as fit() ends: its predictions made again from its point
          fitted_[i] = *kept;
          try
            {
              predictions_[i] = simulate_all(ev.parameters(kept->u), ev.map, ev.runs, ev.options.relative_tolerance,
                                             ev.run_threads);
            }
          catch (const std::exception &)
            {
              // they failed then too: the kept fit says so (failed, message)
            }
          {
            std::lock_guard lock(x_.mutex);
            x_.result.resumed.push_back("round " + std::to_string(index_ + 1) + ": " + kept->effect);
          }
          x_.report(fitted_[i], true);
          return;
        }
      fitted_[i] = fit(ev, predictions_[i]);
      if (x_.store)
        x_.store->keep(index_, fitted_[i]);
      x_.report(fitted_[i]);
    }

    void Round::rank_by_bic()
    {
      for (std::size_t i = 1; i < fitted_.size(); ++i)
        if (!fitted_[i].failed)
          order_.push_back(i);
      std::sort(order_.begin(), order_.end(), [&](auto a, auto b) { return fitted_[a].bic < fitted_[b].bic; });
      judged_ = order_;
    }

    /// none refitted from the best candidate's baseline before any is
    /// judged. none's search starts at the case's values; where the rig lies
    /// far from them it can stop in a basin whose orbit differs (a no-flow
    /// pump's outlet valve shut every cycle), while a candidate's extra
    /// parameter carries its search across to the rig's basin and then does
    /// next to nothing there. So none is refitted from where the best
    /// candidate left the [uncertain] parameters and the gain, and stands
    /// where it fits better: every candidate is then judged against it.
    void Round::refit_none_from_best()
    {
      if (order_.empty() || fitted_[0].failed || !(fitted_[0].bic - fitted_[order_[0]].bic > x_.options.bic_threshold))
        return;
      const auto        began = Clock::now();
      const std::size_t k     = order_[0];
      Evaluator         at_k  = *baseline_ev_;
      at_k.use_effect(todo_[k]);
      const auto          w = at_k.uncertain_units(fitted_[k].u);
      std::vector<double> from;
      for (std::size_t j : baseline_ev_->free)
        from.push_back(w[j]);
      from.push_back(fitted_[k].u.back()); // the gain
      std::vector<Signals> made;
      auto                 again = fit(*baseline_ev_, made, &from, 0.05);
      const bool           kept  = !again.failed && again.bic < fitted_[0].bic;
      rr_.none_restart = {fitted_[k].effect, fitted_[0].bic, again.bic, fitted_[0].rms_train, again.rms_train, kept};
      x_.say("%s; %d runs, %.1f s", none_restart_words(rr_.none_restart).c_str(), again.evaluations,
             seconds_since(began));
      if (kept)
        {
          again.evaluations += fitted_[0].evaluations;
          fitted_[0]      = again;
          predictions_[0] = made;
          rr_.judging.push_back({RoundResult::JudgingStep::Kind::none_refitted});
        }
      else
        fitted_[0].evaluations += again.evaluations;
    }

    /// The candidates judged in BIC order until one is named; where none
    /// is, the nearest miss judged once more with the parameters the case
    /// leaves out tried on (judge_nearest_miss_again).
    void Round::judge_candidates()
    {
      rr_.rules = rules();
      for (int look = 0; look < 2; ++look)
        {
          bic_min_ = 1e300;
          for (const auto &c : fitted_)
            if (!c.failed)
              bic_min_ = std::min(bic_min_, c.bic);
          weight_sum_ = 0;
          for (const auto &c : fitted_)
            if (!c.failed)
              weight_sum_ += std::exp(-0.5 * (c.bic - bic_min_));
          nearest_     = 0;
          near_judged_ = Judgement{};
          if (judge_in_order(look))
            {
              end_judging(look);
              return;
            }
          if (look == 0 && judge_nearest_miss_again())
            continue;
          end_judging(look);
          return;
        }
    }

    /// The candidates in judged_'s order: true where one is named (name()).
    /// An effect that sets a parameter the case leaves out (a hose sets the
    /// outlet passage's inertance) would be named for what that baseline
    /// parameter explains alone: it is named only where it also beats none
    /// with that parameter tried on.
    bool Round::judge_in_order(int look)
    {
      for (std::size_t i : judged_)
        {
          const auto &c = fitted_[i];
          auto        j = judge_one(i, fitted_[0], predictions_[0]);
          rr_.judging.push_back({RoundResult::JudgingStep::Kind::judged, j, scores(c), scores(fitted_[0])});
          if (j.stop())
            return false; // the rest rank lower still
          if (!j.named())
            {
              if (j.near() && j.closed > near_judged_.closed)
                {
                  nearest_     = i;
                  near_judged_ = j;
                }
              continue;
            }
          if (look == 0 && !named_from_ && sets_left_out(todo_[i]))
            {
              const auto &t      = none_tried();
              rr_.set_by_effect = {c.effect, t.left, true, {}, {}, {}, fitted_[0].bic, fitted_[0].rms_train};
              if (t.on)
                {
                  auto again = judge_one(i, t.fit, t.made);
                  if (!again.named())
                    {
                      rr_.set_by_effect.named     = false;
                      rr_.set_by_effect.judgement = again;
                      rr_.set_by_effect.candidate = scores(c);
                      rr_.set_by_effect.baseline  = scores(t.fit);
                      rr_.judging.push_back({RoundResult::JudgingStep::Kind::set_by_effect_rejected, again,
                                             scores(c), scores(t.fit)});
                      continue;
                    }
                  fitted_[0]      = t.fit; // the baseline it is judged, and its verdict given, against
                  predictions_[0] = t.made;
                  j               = again;
                }
            }
          name(i, j);
          return true;
        }
      return false;
    }

    Judgement Round::judge_one(std::size_t i, const CandidateResult &base, const std::vector<Signals> &base_made) const
    {
      return judge(
        scores(fitted_[i]), scores(base), [&] { return dominant_feature(base_made, predictions_[i]); },
        rules());
    }

    /// The signal and half-cycle where the calibrated baseline's residual is
    /// largest, and its RMS there (noise units, over the runs) with the
    /// baseline and with the candidate's predictions `made`.
    FeatureScores Round::dominant_feature(const std::vector<Signals> &base_made, const std::vector<Signals> &made) const
    {
      const auto                 &runs       = x_.runs;
      const std::vector<Signals> &calibrated = base_made.empty() ? x_.current : base_made;
      FeatureScores               f;
      double                      worst = -1;
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          const auto L = localise(runs[r].run, calibrated[r], runs[r].setup.frequency_Hz, runs[r].scales);
          const auto v = L.signals.at(L.dominant_signal).rms_normalised;
          if (v > worst)
            {
              worst    = v;
              f.signal = L.dominant_signal;
              f.half   = L.dominant_half;
            }
        }
      const auto feature = [&](const std::vector<Signals> &model) {
        double sum = 0;
        for (std::size_t r = 0; r < runs.size(); ++r)
          {
            const double v = half_cycle_residual(runs[r].run, model[r], runs[r].setup.frequency_Hz, f.signal, f.half,
                                                 runs[r].scales);
            sum += v * v;
          }
        return std::sqrt(sum / static_cast<double>(runs.size()));
      };
      f.before = feature(calibrated);
      f.after  = feature(made);
      return f;
    }

    /// An effect that sets one of the parameters the case leaves out.
    bool Round::sets_left_out(const Effect *e) const
    {
      const auto &base = baseline_ev_->base;
      return e && std::any_of(base.uncertain.begin(), base.uncertain.end(), [&](const system::UncertainParameter &q) {
               return q.off_at_zero && !(base.real_value(q.table, q.key) > 0.0) && e->sets(q.table, q.key);
             });
    }

    const Round::NoneTried &Round::none_tried()
    {
      if (!none_with_)
        {
          none_with_.emplace(NoneTried{*baseline_ev_, fitted_[0], predictions_[0], {}, false});
          none_with_->left = calibrate_left_out(none_with_->ev, none_with_->fit, none_with_->made, x_.cores);
          none_with_->on   = none_with_->ev.free.size() > baseline_ev_->free.size();
        }
      return *none_with_;
    }

    /// Candidate i named (judgement j): the round's result, then its fit refined.
    void Round::name(std::size_t i, const Judgement &j)
    {
      const auto &c     = fitted_[i];
      rr_.effect        = c.effect;
      rr_.values        = c.values;
      rr_.force_gain    = c.force_gain;
      rr_.baseline      = c.baseline;
      rr_.confidence    = std::exp(-0.5 * (c.bic - bic_min_)) / weight_sum_;
      rr_.signature_explained = true;
      rr_.feature             = j.feature;
      const bool  second      = order_.size() > 1;
      const auto &next        = second ? fitted_[order_[order_[0] == i ? 1 : 0]] : c;
      rr_.named = {fitted_[0].bic - c.bic, c.rms_heldout, fitted_[0].rms_heldout, second ? next.effect : "-",
                   second ? next.bic - c.bic : 0.0};
      x_.current   = predictions_[i];
      Evaluator ev = named_from_ ? *named_from_ : *baseline_ev_; // one fit: its runs at once
      if (!named_from_)
        ev.use_effect(todo_[i]);
      ev.reference      = nullptr;
      ev.run_threads    = x_.cores;
      ev.horizon_cycles = 0; // its refits see every training cycle
      refine_named(x_, rr_, c, std::move(ev), named_from_.has_value());
    }

    /// The nearest miss, judged again with the baseline complete. A
    /// parameter the case leaves out (the outlet passage) is tried on only
    /// at a named effect's fit; where nothing is named and more than the
    /// noise floor remains, "beyond the library" would be said of a baseline
    /// that still lacks it. So it is tried on at none's fit and at the fit
    /// of the candidate that came nearest (it passed the BIC and held-out
    /// rules and closed at least restart_closure x min_gap_closed of the
    /// gap), and that candidate is judged again against none with it, by
    /// the same rules. Only it: the others were further from being named.
    /// True where it is to be judged again (a parameter turned on).
    bool Round::judge_nearest_miss_again()
    {
      if (!(nearest_ > 0 && !left_off_.empty() &&
            near_judged_.closed >= restart_closure * x_.options.min_gap_closed &&
            pooled_norms(x_.runs, predictions_[0], false).at("overall") > x_.options.beyond_library_noise_units))
        return false;
      const auto      began     = Clock::now();
      const auto      k         = nearest_;
      const auto     &at_none   = none_tried();
      const auto     &none_left = at_none.left;
      Evaluator       near_ev   = *baseline_ev_;
      near_ev.use_effect(todo_[k]);
      CandidateResult near_with = fitted_[k];
      auto            near_made = predictions_[k];
      const auto      near_left = calibrate_left_out(near_ev, near_with, near_made, x_.cores);
      rr_.near_miss = {fitted_[k].effect,
                       near_judged_,
                       scores(fitted_[k]),
                       scores(fitted_[0]),
                       fitted_[0].bic,
                       fitted_[0].rms_train,
                       fitted_[k].bic,
                       fitted_[k].rms_train,
                       none_left,
                       near_left,
                       false};
      x_.say("%s, %.1f s", nearest_miss_tried_words(rr_.near_miss).c_str(), seconds_since(began));
      const bool near_on = std::any_of(near_left.begin(), near_left.end(),
                                       [](const BaselineParameter &b) { return b.value != 0.0; });
      rr_.judging.push_back({RoundResult::JudgingStep::Kind::nearest_miss_tried});
      if (!at_none.on && !near_on)
        return false;
      rr_.judging.back().changed = true;
      saved_none_      = fitted_[0];
      saved_near_      = fitted_[k];
      saved_made_      = {predictions_[0], predictions_[k]};
      fitted_[0]       = at_none.fit; // (its runs counted with the tries')
      predictions_[0]  = at_none.made;
      fitted_[k]       = near_with;
      predictions_[k]  = near_made;
      near_ev.reference = nullptr;
      named_from_.emplace(near_ev);
      judged_ = {k};
      return true;
    }

    /// After the last look: the nearest miss's fits restored where it was
    /// not named with the parameters tried on either; none's result where
    /// nothing was named.
    void Round::end_judging(int look)
    {
      if (look == 1 && !rr_.effect) // not named with them either: as before the try
        {
          const std::size_t k = judged_.front();
          fitted_[0]          = *saved_none_;
          fitted_[k]          = *saved_near_;
          predictions_[0]     = saved_made_[0];
          predictions_[k]     = saved_made_[1];
          rr_.judging.push_back({RoundResult::JudgingStep::Kind::fits_without_stand});
        }
      else if (look == 1)
        rr_.near_miss.named = true;
      if (!rr_.effect)
        {
          const auto &none = fitted_[0];
          rr_.values       = {};
          rr_.force_gain   = none.force_gain;
          rr_.baseline     = none.baseline;
          rr_.confidence   = std::exp(-0.5 * (none.bic - bic_min_)) / weight_sum_;
          x_.current       = predictions_[0];
        }
    }

    // ------------------------------------------------------------ Diagnosis

    /// A diagnosis: the runs prepared, the rounds, the sensors' lags, the verdict.
    class Diagnosis
    {
    public:
      Diagnosis(const system::SystemParameters &base, const system::ValveMaps &map, std::vector<RunCase> runs,
                const DiagnoseOptions &options)
        : x_(base, map, std::move(runs), options)
      {}

      DiagnosisResult run()
      {
        const auto start = Clock::now();
        if (x_.runs.empty())
          throw InputError("diagnose: no measured runs given");
        x_.cores = x_.options.threads ? x_.options.threads : std::max(1u, std::thread::hardware_concurrency());
        LendCores lend(x_.cores);
        prepare_runs();
        simulate_the_case();
        open_checkpoint();
        for (int round = 0; round < std::max(1, x_.options.rounds); ++round)
          {
            const RoundResult rr = Round(x_, round).run();
            x_.result.rounds.push_back(rr);
            start_next_round_from(rr);
            if (!rr.effect)
              break;
          }
        x_.result.final_parameters     = x_.base;
        x_.result.after                = x_.current;
        x_.result.residual_before      = pooled_norms(x_.runs, x_.result.before, false);
        x_.result.residual_after_ideal = pooled_norms(x_.runs, x_.result.after, false);
        fit_sensor_lags();
        x_.result.residual_after     = pooled_norms(x_.runs, x_.result.after, false);
        x_.result.baseline_sd_factor = std::sqrt(1.0 / std::max(mean_band_fraction(x_.runs), 1e-12));
        give_verdict();
        x_.result.swing_before         = pooled_norms(x_.runs, x_.result.before, true);
        x_.result.swing_after          = pooled_norms(x_.runs, x_.result.after, true);
        x_.result.runs                 = x_.runs;
        x_.result.wall_time_s          = seconds_since(start);
        x_.result.runs_evaluated_ahead = core_use().handed_over;
        return std::move(x_.result);
      }

    private:
      void prepare_runs();
      void simulate_the_case();
      void open_checkpoint();
      void start_next_round_from(const RoundResult &rr);
      void fit_sensor_lags();
      void give_verdict();

      Context x_;
    };

    /// Each run's start and noise scales with the case's model; one kind
    /// of drive; the candidates.
    void Diagnosis::prepare_runs()
    {
      auto &runs = x_.runs;
      choose_start(x_.base_in, x_.map, runs, x_.options, x_.cores);
      calibrate_noise(x_.base_in, x_.map, runs, x_.options.relative_tolerance, x_.cores);
      x_.traits.scenario      = runs.front().setup.scenario;
      x_.traits.voltage_drive = runs.front().run.drive_column() == "voltage_V";
      for (const auto &rc : runs)
        if (rc.run.drive_column() != runs.front().run.drive_column())
          throw InputError("'" + rc.run.source + "' is driven by " + rc.run.drive_column() + ", '" +
                           runs.front().run.source + "' by " + runs.front().run.drive_column() +
                           ": give runs of one kind of drive");
      if (x_.options.effects.empty())
        x_.library = effect_library();
      else
        for (const auto &name : x_.options.effects)
          x_.library.push_back(find_effect(name));
    }

    /// The candidates' fits kept as each ends, and those an interrupted run kept.
    void Diagnosis::open_checkpoint()
    {
      if (!x_.options.checkpoint_dir.empty())
        x_.store.emplace(x_.options, [this](const std::string &line) {
          if (x_.options.progress)
            x_.options.progress(line);
        });
    }

    /// The case's model as given: each run simulated, where it disagrees,
    /// the trends over the runs.
    void Diagnosis::simulate_the_case()
    {
      auto &runs    = x_.runs;
      auto &result  = x_.result;
      x_.base       = x_.base_in;
      result.before = simulate_all(x_.base, x_.map, runs, x_.options.relative_tolerance, x_.cores);
      for (std::size_t r = 0; r < runs.size(); ++r)
        result.localisation.push_back(
          localise(runs[r].run, result.before[r], runs[r].setup.frequency_Hz, runs[r].swings));
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          const auto &d = runs[r].run.signal(runs[r].run.drive_column());
          result.run_levels.push_back(
            {runs[r].setup.frequency_Hz, *std::max_element(d.begin(), d.end()) - *std::min_element(d.begin(), d.end()),
             residual_norms(runs[r].run, result.before[r], runs[r].swings, runs[r].n_skip).at("overall")});
        }
      x_.current             = result.before;
    }

    /// The model the next round starts from: the baseline as fitted, the
    /// gain, the named effect applied (an [uncertain] parameter it sets is
    /// the effect's now).
    void Diagnosis::start_next_round_from(const RoundResult &rr)
    {
      auto &base = x_.base;
      base.transducer.piezomagnetic_coefficient_m_per_A *= rr.force_gain;
      for (const auto &q : base.uncertain)
        if (rr.baseline.count(q.name()))
          *base.real_field(q.table, q.key) = rr.baseline.at(q.name());
      if (!rr.effect)
        return;
      const auto e = find_effect(*rr.effect);
      e->apply(rr.values, base);
      x_.named.push_back(*rr.effect);
      std::erase_if(base.uncertain, [&](const system::UncertainParameter &q) { return e->sets(q.table, q.key); });
    }

    /// The sensors' lags, fitted to the final model (and, for the verdict's
    /// comparison, to the baseline fit on its own): what a record's
    /// transducers do to it is no part of the pump's physics.
    void Diagnosis::fit_sensor_lags()
    {
      const auto &options = x_.options;
      auto       &result  = x_.result;
      if (options.sensor_lowest_bandwidth_Hz.empty())
        return;
      const auto began   = Clock::now();
      result.sensor_lags = calibrate_sensor_lags(x_.runs, result.after, options.sensor_lowest_bandwidth_Hz);
      if (!x_.baseline_prediction.empty())
        (void)calibrate_sensor_lags(x_.runs, x_.baseline_prediction, options.sensor_lowest_bandwidth_Hz);
      if (!options.progress)
        return;
      std::string line = "  sensor lags fitted to the final model:";
      char        buf[200];
      for (const auto &l : result.sensor_lags)
        {
          if (std::isinf(l.fitted_Hz))
            std::snprintf(buf, sizeof buf, " %s ideal (%.3g noise units);", l.signal.c_str(), l.residual_ideal);
          else
            std::snprintf(buf, sizeof buf, " %s %.3g kHz%s (%.3g -> %.3g noise units; held out %.3g -> %.3g%s);",
                          l.signal.c_str(), 1e-3 * l.fitted_Hz, l.at_lowest() ? ", its lowest" : "",
                          l.residual_ideal, l.residual_lagged, l.heldout_ideal, l.heldout_lagged,
                          l.kept ? "" : ": not kept");
          line += buf;
        }
      std::snprintf(buf, sizeof buf, " %.2f s", seconds_since(began));
      options.progress(line + buf);
    }

    /// The verdict (verdict.h) and where the rest lies: the final model's
    /// largest residual in noise units, the units the verdict counts.
    void Diagnosis::give_verdict()
    {
      auto       &runs        = x_.runs;
      auto       &result      = x_.result;
      const double floor_units = x_.options.beyond_library_noise_units;
      const double baseline    = x_.baseline_prediction.empty() ?
                                   result.residual_after.at("overall") :
                                   pooled_norms(runs, x_.baseline_prediction, false).at("overall");
      const double after       = result.residual_after.at("overall");
      result.residual_baseline  = baseline;
      result.explained_fraction = explained_fraction(baseline, after);
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          result.remaining.push_back(residuals_in_noise_units(runs[r].run, result.after[r], runs[r].setup.frequency_Hz,
                                                              runs[r].swings, runs[r].scales, runs[r].n_skip));
          result.remaining_before.push_back(residuals_in_noise_units(runs[r].run, result.before[r],
                                                                     runs[r].setup.frequency_Hz, runs[r].swings,
                                                                     runs[r].scales, runs[r].n_skip));
        }
      const bool named   = result.rounds.front().effect.has_value();
      result.verdict     = verdict_of(named, after, floor_units);
      result.floor_units             = floor_units;
      // Nothing named, but the calibrated baseline moved a quantity a
      // candidate shares with it (the high side's compliance: a longer oil
      // column or a soft seal) beyond what the case holds: the record cannot
      // tell the two apart
      if (named)
        return;
      result.absorbed_by_baseline =
        absorbed_by_baseline(x_.library, x_.base_in, result.final_parameters, x_.options.absorbed_factor);
    }
  } // namespace

  DiagnosisResult diagnose(const system::SystemParameters &base, const system::ValveMaps &map,
                           std::vector<RunCase> runs, const DiagnoseOptions &options)
  {
    try
      {
        return Diagnosis(base, map, std::move(runs), options).run();
      }
    catch (...)
      {
        if (!options.checkpoint_dir.empty())
          discard_if_nothing_kept(options.checkpoint_dir, options.checkpoint_dir_made);
        throw;
      }
  }
} // namespace rectify::diagnosis
