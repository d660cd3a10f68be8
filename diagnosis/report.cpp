#include "diagnosis/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/case_edit.h"
#include "common/io.h"
#include "common/plot.h"
#include "common/version.h"
#include "diagnosis/fit.h"
#include "diagnosis/words.h"

namespace rectify::diagnosis
{
  namespace
  {
    /// `words` between `before` and `after`, or nothing where it is empty.
    std::string wrapped(const char *before, const std::string &words, const char *after)
    {
      return words.empty() ? std::string() : before + words + after;
    }

    std::string sci(double v)
    {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.4g", v);
      return buf;
    }

    std::string pretty_signal(const std::string &s)
    {
      return s == "outlet_pressure_Pa" ? "outlet pressure [MPa]" :
             s == "chamber_pressure_Pa" ? "chamber pressure [MPa]" :
             s == "outlet_valve_m" ? "outlet valve opening [um]" :
             s == "actuator_position_m" ? "actuator position [mm]" :
             s == "actuator_velocity_m_per_s" ? "actuator velocity [mm/s]" : s;
    }

    double display_scale(const std::string &s)
    {
      return s.ends_with("_Pa") ? 1e-6 : s == "outlet_valve_m" ? 1e6 : s.ends_with("_m") || s.ends_with("_m_per_s") ? 1e3 : 1.0;
    }


    /// The named effect's part of its round's section.
    std::string named_section(const RoundResult &rr, const DiagnoseOptions &options)
    {
      std::string md;
      const auto e = find_effect(*rr.effect);
      md += e->physics() + ".\n\nExpected signature: " + e->signature() + ".\n\n";
      for (std::size_t i = 0; i < rr.values.size(); ++i)
        md += "- " + e->parameters()[i].meaning + ": `" + e->parameters()[i].key + " = " + sci(rr.values[i]) +
              "` (bounds " + sci(e->parameters()[i].lower) + " .. " + sci(e->parameters()[i].upper) + ")\n";
      for (const auto &q : rr.uncertainty)
        md += "- `" + q.key + "`: standard error " +
              (std::isinf(q.relative_sd) ? std::string("more than ") + sci(100 * options.determined_relative_sd)
                                         : sci(100 * q.relative_sd)) +
              " % from its profile (held at " + sci(q.profile_value[0]) + " and " + sci(q.profile_value[1]) +
              " with the baseline refitted: training residual " + sci(q.profile_rms[0]) + " and " +
              sci(q.profile_rms[1]) + " noise units against the fit's " + sci(q.rms_at_fit) +
              "), one standard error " +
              (std::isnan(q.lower) ? "below " + sci(q.profile_value[0]) : sci(q.lower)) + " .. " +
              (std::isnan(q.upper) ? "above " + sci(q.profile_value[1]) : sci(q.upper)) + "; locally " +
              sci(100 * q.local_relative_sd) + " % (" + sci(100 * q.local_relative_sd_given_baseline) +
              " % with the baseline known), most correlated with `" + q.correlated_with + "` (" +
              sci(q.correlation) + ")" + (q.determined ? "" : ": **not determined by the record**") + "\n";
      if (rr.combined)
        md += "- " + rr.combined->meaning + ": `" + rr.combined->name + " = " + sci(rr.combined->value) +
              "`, standard error " + sci(100 * rr.combined->relative_sd) + " %" +
              (rr.combined->determined ? "" : " (not determined either)") + "\n";
      md += "- confidence (BIC weight): " + sci(rr.confidence) + "\n";
      if (rr.refine_passes > 0)
        md += "- refitted " + std::to_string(rr.refine_passes) +
              " time(s) with the residual's noise scales recomputed from the fitted model (the "
              "candidates' table below shows the first fit, on which the choice was made)\n";
      for (const auto &m : rr.profile_moves)
        md += "- moved along its profile to `" + sci(m["value"].get<double>()) +
              "`: that side of the profile, with the baseline refitted, fitted better (training residual " +
              sci(m["training_residual"].get<double>()) + " noise units, evidence " +
              sci(m["evidence"].get<double>()) + "); refitted from there\n";
      for (const auto &b : rr.freed)
        md += "- `" + b.name + "` freed for the refits: " +
              (b.effect_shape ? "the effect's own shape, held at the case's value while the model had "
                                "no such effect, determined at this effect's settled fit"
                              : "held at the baseline fit, determined at this effect's fit") +
              " (standard error " + sci(b.sd_unit) + " of its range" +
              wrapped("; ", standing_words(b), "") + "); refitted from the case's " + sci(b.nominal) +
              " to " + sci(rr.baseline.count(b.name) ? rr.baseline.at(b.name) : b.value) + "\n";
      for (const auto &b : rr.left_out)
        md += "- `" + b.name + "`, which the case leaves out (0), tried on at this effect's settled fit: " +
              (b.value != 0.0 ? "on, refitted to " +
                                  sci(rr.baseline.count(b.name) ? rr.baseline.at(b.name) : b.value)
                              : std::string("off")) +
              " (" + standing_words(b) + ")\n";
      return md;
    }

    /// One round's section: the named effect, its parameters and how sure,
    /// the evidence, the candidates' table.
    std::string round_section(const RoundResult &rr, std::size_t k, const DiagnoseOptions &options)
    {
      std::string md;
      md += "\n## Round " + std::to_string(k + 1) + ": " +
            (!rr.effect ? std::string("no significant missing effect") : "**" + *rr.effect + "**") + "\n\n";
      if (rr.effect)
        md += named_section(rr, options);
      md += "- force gain (nuisance): " + sci(rr.force_gain) + "\n- evidence: " + decision_words(rr) + "\n\n";
      md += "| candidate | k | BIC - BIC(none) | AIC | RMS train | RMS held-out | parameters |\n|---|---|---|---|---|---|---|\n";
      double none_bic = 0;
      for (const auto &c : rr.candidates)
        if (c.effect == "none")
          none_bic = c.bic;
      for (const auto &c : rr.candidates)
        {
          if (!c.not_testable.empty())
            {
              md += "| " + c.effect + " | | not testable: " + c.not_testable + " | | | | |\n";
              continue;
            }
          std::string params;
          if (c.effect != "none")
            {
              const auto e = find_effect(c.effect);
              for (std::size_t i = 0; i < c.values.size(); ++i)
                params += e->parameters()[i].key + " = " + sci(c.values[i]);
            }
          md += "| " + c.effect + " | " + std::to_string(c.k) + " | " + sci(c.bic - none_bic) + " | " + sci(c.aic) +
                " | " + sci(c.rms_train) + " | " + sci(c.rms_heldout) + " | " + params + " |\n";
        }
      return md;
    }

    class Report
    {
    public:
      Report(const DiagnosisResult &result, const std::vector<RunCase> &runs, const system::ValveMaps &map,
             const ReportInputs &in, const std::filesystem::path &out, bool made_out)
        : result(result)
        , runs(runs)
        , map(map)
        , in_(in)
        , o(in)
        , p(in.case_parameters)
        , second_mode(in.second_mode)
        , file_second_mode_Hz(in.file_second_mode_Hz)
        , out(out)
        , made_out(made_out)
      {}

      std::string write()
      {
        summary = to_json(result, runs);
        summary.update({{"command", "diagnose"},
                        {"rectify_version", RECTIFY_VERSION},
                        {"build", build_info()},
                        {"case", in_.case_path},
                        {"scenario", in_.scenario},
                        {"baseline_second_mode",
                         {{"frequency_Hz", second_mode.frequency_Hz}, {"reason", second_mode.reason}}},
                        {"data", in_.data}});
        write_new_case();
        write_overlays();
        summary["files"] = files;
        summary["total_wall_time_s"] =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - in_.started).count();
        write_candidates();
        write_file_atomic(out / "report.md", report_md());
        write_json(out / "summary.json", summary);
        return case_name;
      }

    private:
      std::vector<CaseEntry> new_case_entries();
      void                   write_new_case();
      void                   write_overlays();
      void                   write_candidates();
      std::string            report_md() const;
      std::string            records_section() const;
      std::string            baseline_section() const;
      std::string            before_section() const;
      std::string            gap_section() const;
      std::string            sensors_section() const;
      std::string            after_section() const;

      const DiagnosisResult       &result;
      const std::vector<RunCase>  &runs;
      const system::ValveMaps     &map;
      const ReportInputs          &in_;
      const ReportInputs          &o; ///< (case_path, scenario, options)
      const system::SystemParameters &p;
      const BaselineSecondMode    &second_mode;
      const double                 file_second_mode_Hz;
      const std::filesystem::path  out;
      const bool                   made_out;
      nlohmann::json               summary;
      std::string                  effects_named; ///< "valve_leakage+line_inertance"
      std::string                  case_name;     ///< the new case file's
      std::vector<std::string>     files;
    };

    /// The new case file's keys: the named effects' (as applied), the
    /// baseline's second mode where the diagnosis set it, every [uncertain]
    /// parameter and the force gain as fitted.
    std::vector<CaseEntry> Report::new_case_entries()
    {
      std::vector<CaseEntry> entries;
      for (const auto &rr : result.rounds)
        if (rr.effect)
          {
            const auto e = find_effect(*rr.effect);
            effects_named += (effects_named.empty() ? "" : "+") + *rr.effect;
            for (std::size_t i = 0; i < rr.values.size(); ++i) // as applied (a range's end can mean off)
              {
                const auto &spec = e->parameters()[i];
                entries.push_back({spec.table, spec.key,
                                   format_number(result.final_parameters.real_value(spec.table, spec.key)),
                                   "rectify diagnose: " + *rr.effect + " (fitted)"});
              }
            for (const auto &k : e->fixed_keys())
              entries.push_back({k.table, k.key, k.value, "rectify diagnose: " + *rr.effect});
            // a key the case declares [uncertain] that the effect now sets
            // (a second mode): its range no longer holds the effect's value
            for (const auto &q : p.uncertain)
              if (e->sets(q.table, q.key))
                entries.push_back({"uncertain", q.name(), "",
                                   "rectify diagnose: set by " + *rr.effect + " (fitted), no longer a baseline parameter"});
          }
      const bool second_mode_named = std::any_of(entries.begin(), entries.end(), [](const auto &e) {
        return e.table == "reed" && e.key == "second_mode_frequency_Hz";
      });
      if (!second_mode_named && second_mode.frequency_Hz != file_second_mode_Hz)
        entries.push_back({"reed", "second_mode_frequency_Hz", format_number(second_mode.frequency_Hz),
                           "rectify diagnose: the baseline's second mode, " + second_mode.reason});
      for (const auto &q : result.final_parameters.uncertain)
        entries.push_back({q.table, q.key, format_number(result.final_parameters.real_value(q.table, q.key)),
                           "rectify diagnose: uncertain baseline parameter, fitted"});
      entries.push_back({"transducer", "piezomagnetic_coefficient_m_per_A",
                         format_number(result.final_parameters.transducer.piezomagnetic_coefficient_m_per_A),
                         "rectify diagnose: nuisance force gain fitted"});
      return entries;
    }

    /// The new case file, read back and simulated: it must reproduce the
    /// refitted model (with ideal sensors: their fitted lags are no key of it).
    void Report::write_new_case()
    {
      const std::vector<CaseEntry> entries = new_case_entries();
      std::string text;
      {
        std::ifstream     file(in_.case_file);
        std::stringstream ss;
        ss << file.rdbuf();
        text = ss.str();
      }
      case_name = "case-with-" + (effects_named.empty() ? std::string("none") : effects_named) + ".toml";
      const std::string edited =
        "# Written by rectify diagnose from " + std::filesystem::absolute(in_.case_file).string() +
        "\n# with the named effect(s) and the fitted force gain; see summary.json.\n" +
        edit_case_text(text, std::filesystem::path(in_.case_file).parent_path(), entries);
      write_file_atomic(out / case_name, edited);
      // Check: the new case file reproduces the refitted model (a case
      // file that cannot be read back or simulated is not left behind),
      // as it is: with ideal sensors (their fitted lags are no key of it).
      double check = 0;
      try
        {
          const CaseFile new_file = in_.load_case(out / case_name);
          const auto     new_p    = system::SystemParameters::from_case(new_file);
          double         check_sq = 0;
          for (std::size_t r = 0; r < runs.size(); ++r)
            {
              const auto so    = result.runs[r].simulation(o.options.relative_tolerance);
              const auto model = simulate_run(new_p, map, result.runs[r].run, runs[r].setup, so);
              const auto norms = residual_norms(result.runs[r].run, model, result.runs[r].scales,
                                                           result.runs[r].n_skip);
              check_sq += norms.at("overall") * norms.at("overall");
            }
          check = std::sqrt(check_sq / static_cast<double>(runs.size()));
        }
      catch (...)
        {
          std::filesystem::remove(out / case_name);
          std::error_code ec; // a folder made for this run and left empty goes too
          if (made_out && std::filesystem::is_empty(out, ec))
            std::filesystem::remove(out, ec);
          throw;
        }
      summary["new_case"] = {{"file", case_name},
                             {"residual_overall_from_file", check},
                             {"matches_refit", std::abs(check - result.residual_after_ideal.at("overall")) <=
                                                 2e-3 * result.residual_after_ideal.at("overall") + 1e-9}};

    }

    /// Overlays: data, the model before and after, per run (CSV and PNG).
    void Report::write_overlays()
    {
      files = {"summary.json", "report.md", "candidates.csv", case_name};
      for (std::size_t r = 0; r < runs.size(); ++r)
        {
          const auto &rc = runs[r];
          std::vector<std::string> cols{"time_s"};
          std::vector<std::string> sigs;
          for (const auto &[name, v] : result.before[r])
            {
              sigs.push_back(name);
              cols.push_back("data_" + name);
              cols.push_back("before_" + name);
              cols.push_back("after_" + name);
            }
          CsvTable table(cols);
          std::vector<double> row(cols.size());
          for (std::size_t i = 0; i < rc.run.time_s.size(); ++i)
            {
              row[0] = rc.run.time_s[i];
              std::size_t c = 1;
              for (const auto &s : sigs)
                {
                  row[c++] = rc.run.signal(s)[i];
                  row[c++] = result.before[r].at(s)[i];
                  row[c++] = result.after[r].at(s)[i];
                }
              table.add_row(row);
            }
          const std::string base = "overlay-" + std::to_string(r + 1);
          table.write(out / (base + ".csv"));
          files.push_back(base + ".csv");
          // the data as compared: within the band (diagnose.h, `harmonics`)
          const std::string data_label =
            result.runs[r].band_Hz > 0 ? "data (to " + format_number(std::round(result.runs[r].band_Hz)) + " Hz)" : "data";
          std::vector<PlotPanel> panels;
          const std::size_t stride = std::max<std::size_t>(1, rc.run.time_s.size() / 8000);
          for (const auto &s : sigs)
            panels.push_back({pretty_signal(s) + " - " + rc.run.source, "time [s]", pretty_signal(s), false, false,
                              {{out / (base + ".csv"), "time_s", "data_" + s, data_label, "points pt 7 ps 0.3", 1, display_scale(s), stride},
                               {out / (base + ".csv"), "time_s", "before_" + s, "model before", "lines", 1, display_scale(s), stride},
                               {out / (base + ".csv"), "time_s", "after_" + s, "model with " + (effects_named.empty() ? std::string("no effect (refit)") : effects_named), "lines", 1, display_scale(s), stride}}});
          if (render_plot(out / base, panels))
            files.push_back(base + ".png");
        }
    }

    /// candidates.csv: the first round's candidates and their scores.
    void Report::write_candidates()
    {
      std::string csv = "effect,k,bic,delta_bic_vs_none,aic,rms_train,rms_heldout,force_gain,parameters,evaluations,wall_time_s,note\n";
      const auto &cands = result.rounds.front().candidates;
      double      none_bic = 0;
      for (const auto &c : cands)
        if (c.effect == "none")
          none_bic = c.bic;
      for (const auto &c : cands)
        {
          std::string params;
          if (c.effect != "none" && c.not_testable.empty())
            {
              const auto e = find_effect(c.effect);
              for (std::size_t i = 0; i < c.values.size(); ++i)
                params += (params.empty() ? "" : " ") + e->parameters()[i].key + "=" + sci(c.values[i]);
            }
          if (!c.not_testable.empty())
            csv += c.effect + ",,,,,,,,,,,\"not testable: " + c.not_testable + "\"\n";
          else
            csv += c.effect + "," + std::to_string(c.k) + "," + sci(c.bic) + "," + sci(none_bic - c.bic) + "," +
                   sci(c.aic) + "," + sci(c.rms_train) + "," + sci(c.rms_heldout) + "," + sci(c.force_gain) +
                   "," + params + "," + std::to_string(c.evaluations) + "," + sci(c.wall_time_s) + "," +
                   (c.failed               ? "failed: " + c.message :
                    !c.not_restarted       ? std::string() :
                                             "\"" + search_words(c) + "\"") + "\n";
        }
      write_file_atomic(out / "candidates.csv", csv);
    }

    std::string Report::report_md() const
    {
      std::string md = "# rectify diagnose\n\nCase: `" + o.case_path + "`, scenario " + o.scenario + ".\n\n";
      md += "The reeds' second mode in the baseline: " + second_mode.text() + ".\n\n";
      md += "**Verdict: " + to_string(result.verdict) + ".** " + verdict_words(result) + ".\n\n";
      if (const auto words = uncertainty_words(result.rounds.front()); !words.empty())
        md += "Parameters: " + words + ".\n\n";
      md += records_section() + baseline_section() + before_section();
      for (std::size_t k = 0; k < result.rounds.size(); ++k)
        md += round_section(result.rounds[k], k, o.options);
      return md + gap_section() + sensors_section() + after_section();
    }

    std::string Report::records_section() const
    {
      std::string md;
      md += "## The records\n\n| run | start | residual of each start (first 2 cycles, swing units; with the "
            "model that chose it) | "
            "settling samples left out | outliers replaced | compared |\n|---|---|---|---|---|---|\n";
      for (const auto &rc : result.runs)
        {
          std::string scores, spikes;
          for (const auto &[name, v] : rc.start_scores.items())
            scores += (scores.empty() ? "" : ", ") + name + " " + sci(v.get<double>());
          for (const auto &x : rc.outliers)
            spikes += (spikes.empty() ? "" : "; ") + x.column + " row " + std::to_string(x.row) + " (" +
                      sci(x.noise_units) + " sd)";
          md += "| `" + rc.run.source + "` | " + to_string(rc.start) +
                (rc.start_revisions.empty() ? "" : " (" + start_revision_words(rc) + ")") + " | " +
                (scores.empty() ? "-" : scores) + " | " + std::to_string(rc.n_skip) +
                wrapped(" (", settling_words(rc), ")") + " | " +
                (spikes.empty() ? "none" : spikes) + " | " +
                (rc.band_Hz > 0 ? "within " + format_number(rc.harmonics) + " harmonics (to " +
                                    format_number(std::round(rc.band_Hz)) + " Hz; " + band_words(rc) + ")" :
                                  std::string("every sample")) +
                " |\n";
        }
      if (result.compared_cycles_per_run > 0)
        md += "\nThe candidates (none too) were fitted and compared on the first " +
              sci(result.compared_cycles_per_run) +
              " training cycles of each run after its settling (the whole training part of a shorter run; "
              "at most " + sci(o.options.compared_cycles) +
              " in all, `--compared-cycles`); the named effect was then refitted on every training cycle.\n";
      return md;
    }

    std::string Report::baseline_section() const
    {
      std::string md;
      if (!result.rounds.front().baseline_check.empty())
        {
          md += "\n## The baseline, calibrated before naming anything\n\nFitted with `none` (every [uncertain] "
                "parameter and the force gain); a parameter the data do not determine (standard error above " +
                sci(o.options.identifiability_sd) +
                " of its range) is held at this fit for every candidate. The standard error counts every compared "
                "sample as independent; counted per independent value of the band, as the named parameter's is, it "
                "would be about sqrt(n / independent values) larger (here " +
                sci(result.baseline_sd_factor) + "x).\n\n"
                "| parameter | case | fitted | bounds | standard error / range (samples as independent) | identifiable "
                "| note |\n"
                "|---|---|---|---|---|---|---|\n";
          for (const auto &b : result.rounds.front().baseline_check)
            md += "| " + b.name + " | " + sci(b.nominal) + " | " + sci(b.value) + " | " + sci(b.lower) + " .. " +
                  sci(b.upper) + " | " + sci(b.sd_unit) + " | " + (b.identifiable ? "yes" : "no: held") + " | " +
                  standing_words(b) + " |\n";
        }
      return md;
    }

    std::string Report::before_section() const
    {
      std::string md;
      md += "\n## Where the model disagrees with the data (before)\n\nThe case's model as given: each signal's "
            "residual in units of its noise (from the run's settling on), the most first; then how it lies, in "
            "the terms of its swing.\n\n";
      for (std::size_t r = 0; r < result.remaining_before.size() && r < runs.size(); ++r)
        {
          md += "Run `" + runs[r].run.source + "` (" + sci(runs[r].setup.frequency_Hz) + " Hz):\n\n";
          for (const auto &s : result.remaining_before[r])
            md += "- " + residual_words(s) + "\n";
          md += "\n";
        }
      for (const auto &s : trends(result.run_levels))
        md += "- " + s + "\n";
      return md;
    }

    std::string Report::gap_section() const
    {
      std::string md;
      md += "\n## Gap before and after\n\nRMS residual in units of each signal's noise (about 1: explained to within the noise), "
            "and as a fraction of the signal's swing (RMS about its mean).\n\n"
            "| signal | before [noise] | after [noise] | before [swing] | after [swing] |\n|---|---|---|---|---|\n";
      for (const auto &[name, v] : result.residual_before)
        md += "| " + name + " | " + sci(v) + " | " + sci(result.residual_after.at(name)) + " | " +
              sci(result.swing_before.at(name)) + " | " + sci(result.swing_after.at(name)) + " |\n";
      return md;
    }

    std::string Report::sensors_section() const
    {
      std::string md;
      if (!result.sensor_lags.empty())
        {
          md += "\n## The sensors' lags\n\nEach signal's sensor as a first-order lag, fitted to the final model on "
                "the training samples (between the case's lowest bandwidth and an ideal sensor) once everything "
                "else was decided, and kept where the held-out samples (which its fit did not see) fit at "
                "least as well with it; \"after\" is the model seen through the kept lags. Residual in noise "
                "units.\n\n"
                "| signal | fitted bandwidth [kHz] | lowest [kHz] | training: ideal sensor | with the lag "
                "| held out: ideal | with the lag | kept |\n|---|---|---|---|---|---|---|---|\n";
          for (const auto &l : result.sensor_lags)
            md += "| " + l.signal + " | " +
                  (std::isinf(l.fitted_Hz) ? std::string("ideal") :
                                             sci(1e-3 * l.fitted_Hz) + (l.at_lowest() ? " (its lowest)" : "")) +
                  " | " + sci(1e-3 * l.lowest_Hz) + " | " + sci(l.residual_ideal) + " | " + sci(l.residual_lagged) +
                  " | " + sci(l.heldout_ideal) + " | " + sci(l.heldout_lagged) + " | " + (l.kept ? "yes" : "no") +
                  " |\n";
          md += "\nOverall after, with ideal sensors: " + sci(result.residual_after_ideal.at("overall")) +
                " noise units; through the lags: " + sci(result.residual_after.at("overall")) + ".\n";
        }
      return md;
    }

    std::string Report::after_section() const
    {
      std::string md;
      md += "\n## Where the final model still disagrees (after)\n\nEach signal's residual in units of its noise "
            "(from the run's settling on), the most first; then how it lies, in the terms of its swing.\n\n";
      for (std::size_t r = 0; r < result.remaining.size() && r < runs.size(); ++r)
        {
          md += "Run `" + runs[r].run.source + "`:\n\n";
          for (const auto &s : result.remaining[r])
            md += "- " + residual_words(s) + "\n";
          md += "\n";
        }
      md += "New case file: `" + case_name + "`. Overlays: `overlay-N.png`.\n";
      return md;
    }
  } // namespace

  std::string write_report(const DiagnosisResult &result, const std::vector<RunCase> &runs,
                           const system::ValveMaps &map, const ReportInputs &in, const std::filesystem::path &out,
                           bool made_out)
  {
    return Report(result, runs, map, in, out, made_out).write();
  }
} // namespace rectify::diagnosis
