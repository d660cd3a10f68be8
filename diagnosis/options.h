// A diagnosis's settings (diagnose(), docs/diagnosis.md): every stage reads
// its own from here.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace rectify::diagnosis
{
  struct DiagnoseOptions
  {
    double              training_fraction  = 0.75;
    /// CVODE's: its error (1e-4 of a signal's swing) stays far below 1 % noise,
    /// and each fit runs the model some twenty times per candidate.
    double              relative_tolerance = 1e-5;
    double              bic_threshold      = 10.0;
    /// A named effect must close at least this share of the gap above the
    /// noise (sqrt(rms^2 - 1)) that the calibrated baseline leaves.
    double              min_gap_closed     = 0.5;
    int                 grid_points        = 9;  ///< coarse start grid per effect parameter
    int                 max_evaluations    = 40; ///< BOBYQA's, per candidate
    double              gain_range         = 0.1; ///< nuisance force gain in 1 +- this
    /// Where each record starts: "auto" (the one of rest, record,
    /// record-mean (no-flow runs), steady and periodic whose model fits the
    /// record's first two cycles best, with the case's baseline; earlier
    /// ones win within 5 %, a recorded state against a run-in within 20 %),
    /// or one of them for every run (observation.h).
    std::string         start              = "auto";
    double              lead_cycles        = 10;  ///< run-in before a periodic start (steady: 3)
    /// Cycles at the start of each record left out of every residual
    /// (the estimated start state is approximate); < 0: 0 for a rest start,
    /// otherwise the model's memory of its start (settle), at least 1.
    double              settling_cycles    = -1;
    /// The model's memory of its start ends at the first cycle from which
    /// its runs from two starts differ by at most this many noise units
    /// (RMS over each later training cycle): settle.
    double              settling_tolerance = 1.0;
    bool                repair_outliers    = true; ///< find isolated spikes, report and replace them
    /// Data and model are compared within the first `harmonics` harmonics of
    /// the pumping frequency (both band-limited at (harmonics + 0.5) f): fast
    /// ringing and flutter, which two models of one pump reproduce
    /// differently and which a measured drive's noise sets, do not decide.
    /// 0: the whole band.
    double              harmonics          = 10;
    /// "auto" (harmonics_auto): in a loaded run the band also stops below
    /// half the outlet reed's natural frequency (reed_frequency_Hz), at
    /// least one harmonic: the valves are off their seats for most of every
    /// cycle and flutter near that frequency, which two models of one reed
    /// (one mode or two, an exact or a penalty seat) reproduce with other
    /// phases. In a no-flow run the valves open briefly and the band stays.
    bool                harmonics_auto     = true;
    /// A baseline parameter ([uncertain] in the case, and the force gain)
    /// whose standard error at the baseline fit exceeds this share of its
    /// (log) range is reported and held at that fit's value, not traded
    /// against an effect.
    double              identifiability_sd = 0.15;
    /// A named effect's parameter is reported as determined by the record
    /// when its standard error (with the baseline's uncertain parameters
    /// unknown within their ranges) is at most this share of its value.
    double              determined_relative_sd = 0.2;
    /// A residual left above this many noise units after the fit means model
    /// error beyond the library (the verdict says so).
    double              beyond_library_noise_units = 2.0;
    /// Where nothing is named and the calibrated baseline holds a quantity
    /// a candidate shares with it (Effect::Combination) at more than this
    /// many times the case's, the verdict says the candidate would look
    /// the same (DiagnosisResult::absorbed_by_baseline).
    double              absorbed_factor = 2.0;
    int                 refine_passes      = 3;  ///< at most, after naming (see diagnose.cpp)
    /// A named effect's fit moves to a side of its profile that fits
    /// better by more than bic_threshold, refitted and profiled again, at
    /// most this many times (0: never; the profile only reports it).
    int                 max_profile_moves  = 2;
    /// The candidates (none too) are fitted and compared on at most this
    /// many training cycles in all, after each run's settling, the same
    /// number from each run that has them (screening_cycles_per_run); the
    /// named effect is then refitted on every training cycle. 0: every
    /// training cycle. A single record of the study's length (16 cycles,
    /// 12 of them training) is compared whole.
    double              compared_cycles    = 32;
    /// Per measured signal: its sensor's lowest bandwidth [Hz]. Once the
    /// model is chosen, each such signal's lag is fitted between that and
    /// an ideal sensor (sensors.h) and the residual reported with it.
    /// Empty: ideal sensors.
    std::map<std::string, double> sensor_lowest_bandwidth_Hz;
    std::vector<std::string> effects;              ///< candidates; empty: the whole library
    unsigned            threads = 0;               ///< 0: all cores
    int                 rounds  = 1;               ///< 2: look for a second effect
    std::function<void(const std::string &)> progress; ///< one line per finished candidate, named fit refit, left-out try and profile
    /// Where each candidate's fit is kept the moment it ends (a folder:
    /// DIR/diagnosis-partial.csv and .json, common/checkpoint.h; empty:
    /// nowhere). A diagnosis started again with the same fingerprint takes
    /// the fits kept there instead of fitting those candidates again: an
    /// interrupted run resumes. The fingerprint holds what makes the fits
    /// the same (the tool's revision, every option, the inputs' hashes); kept
    /// fits with another are discarded, and so are they all where a round's
    /// `none`, fitted again first, differs from the kept one in any bit.
    std::filesystem::path checkpoint_dir;
    nlohmann::json        checkpoint_fingerprint;
    /// checkpoint_dir was made for this diagnosis: one that fails before
    /// any fit is kept removes it again (discard_if_nothing_kept).
    bool                  checkpoint_dir_made = false;
  };
} // namespace rectify::diagnosis
