// What every stage of one diagnosis reads and writes (diagnose.cpp and
// named_refit.cpp): its inputs, the model as the rounds leave it, the
// result as it grows, and the progress lines.
#pragma once

#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "diagnosis/effect.h"
#include "diagnosis/options.h"
#include "diagnosis/results.h"
#include "maps/resistance_map.h"
#include "diagnosis/kept_fits.h"
#include "diagnosis/words.h"

namespace rectify::diagnosis
{
  /// What every stage of a diagnosis reads: its inputs, the model as the
  /// rounds leave it, the result as it grows, the progress lines.
  struct Context
  {
    Context(const system::SystemParameters &base_in, const system::ValveMaps &map, std::vector<RunCase> runs,
            const DiagnoseOptions &options)
      : base_in(base_in)
      , map(map)
      , runs(std::move(runs))
      , options(options)
    {}

    const system::SystemParameters            &base_in;
    const system::ValveMaps                   &map;
    std::vector<RunCase>                       runs;
    const DiagnoseOptions                     &options;
    unsigned                                   cores = 1;
    RunTraits                                  traits;
    std::vector<std::shared_ptr<const Effect>> library;
    system::SystemParameters                   base;    ///< the model the next round starts from
    std::vector<Signals>                       current; ///< its predictions, per run
    std::vector<Signals>                       baseline_prediction; ///< the first round's none
    std::optional<FitStore>                    store;   ///< the candidates' fits, kept as each ends
    std::vector<std::string>                   named;
    DiagnosisResult                            result;
    std::mutex                                 mutex; ///< for the progress lines

    /// A progress line (printf's format).
    template <typename... Args>
    void say(const char *format, Args... args)
    {
      if (!options.progress)
        return;
      std::string line(static_cast<std::size_t>(std::snprintf(nullptr, 0, format, args...)), '\0');
      std::snprintf(line.data(), line.size() + 1, format, args...); // whole, however long
      std::lock_guard lock(mutex);
      options.progress(line);
    }

    /// A candidate's fit as a progress line.
    void report(const CandidateResult &c, bool kept = false)
    {
      if (!options.progress)
        return;
      std::lock_guard lock(mutex);
      char            buf[256];
      std::snprintf(buf, sizeof buf, "fitted %-18s BIC %.6g, held-out RMS %.4g, %d runs of the model, %.1f s",
                    c.effect.c_str(), c.bic, c.rms_heldout, c.evaluations, c.wall_time_s);
      std::string line = buf;
      if (const auto search = search_words(c); !search.empty())
        line += "; " + search;
      if (const auto ringing = ringing_words(c); !ringing.empty())
        {
          std::snprintf(buf, sizeof buf, "; ringing starts (%d of the runs, over 3-6 cycles, %.1f s): ",
                        c.ringing_runs, c.ringing_time_s);
          line += buf + ringing;
        }
      if (kept)
        line += " (kept by the interrupted run: not fitted again)";
      options.progress(line);
    }
  };
} // namespace rectify::diagnosis
