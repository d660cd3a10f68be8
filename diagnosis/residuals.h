// Residuals between a measured run and the model, and where they lie
// (issue 4, step 2): which signal, which part of the pumping cycle
// (pressurising stroke or refill), which harmonics of the pumping frequency,
// which trend over the record and over the runs' frequencies and amplitudes.
//
// Residuals are normalised per signal by a scale: in the fits and scores the
// signal's expected noise (diagnose.h), in the words its swing (RMS about its
// mean), so that pressures, openings and strains add up.
#pragma once

#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "diagnosis/measured_run.h"
#include "diagnosis/observation.h"

namespace rectify::diagnosis
{
  /// Each measured signal's swing: its RMS about its mean.
  std::map<std::string, double> signal_scales(const MeasuredRun &run);

  /// Standard deviation of the white (sample-to-sample) noise on a densely
  /// sampled signal, from its second differences d (var d = 6 sd^2 for white
  /// noise), robustly: 1.4826 median|d - median d| / sqrt(6).
  double white_noise_sd(const std::vector<double> &values);

  /// The scatter of a signal from cycle to cycle: per phase of the cycle
  /// (uniform sampling, a whole number of samples per cycle to 1 %), a
  /// quadratic in the cycle index through its values in the cycles of the
  /// record's second half (at least 5; so a slow build-up or drift is not
  /// counted), the residuals' RMS (for the quadratic's three parameters). What the record does not repeat:
  /// noise of any colour, flutter. 0 if it cannot be measured.
  double cycle_scatter(const std::vector<double> &times, const std::vector<double> &values,
                       double frequency_Hz);

  /// The frequencies [Hz] of up to `count` spectral peaks of uniformly
  /// sampled values in [f_low, f_high] (Hann window, zero-padded to 8x,
  /// each peak interpolated by a parabola through its log magnitudes): a
  /// ringing in a residual. Largest first: the largest bin, then local
  /// maxima of the magnitude at least `min_share` of the largest, each
  /// more than `separation` (relative) away from every peak already found. A ringing line shows its lowest mode and
  /// the ones above it; the largest need not be the lowest. A ringing
  /// re-excited every pumping cycle also has sidebands one pumping
  /// frequency apart, which can count as peaks. Empty if the record is too
  /// short or not uniformly sampled.
  std::vector<double> spectral_peaks(const std::vector<double> &times, const std::vector<double> &values,
                                     double f_low_Hz, double f_high_Hz, std::size_t count,
                                     double min_share = 0.3, double separation = 0.15);

  /// The pumping cycle's phase in [0, 1) at the record's first sample: 0 at
  /// the drive's minimum (the fundamental's), 0.5 at its maximum. A record
  /// that starts mid-operation starts anywhere in the cycle; the
  /// pressurising half is phase [0, 0.5).
  double drive_phase_at_start(const MeasuredRun &run, double frequency_Hz);

  /// Sum of squared normalised residuals over samples [from, to) of every
  /// signal in `model`, and the number of terms.
  struct SquaredResidual
  {
    double      sum = 0;
    std::size_t n   = 0;
  };
  SquaredResidual squared_residual(const MeasuredRun &run, const Signals &model,
                                   const std::map<std::string, double> &scales, std::size_t from,
                                   std::size_t to);

  /// The normalised residuals themselves over samples [from, to), signal by
  /// signal, appended to `out`.
  void append_residuals(const MeasuredRun &run, const Signals &model,
                        const std::map<std::string, double> &scales, std::size_t from, std::size_t to,
                        std::vector<double> &out);

  /// Normalised RMS residual per signal from sample `from` to the end of the
  /// record, and "overall" (the RMS over signals).
  std::map<std::string, double> residual_norms(const MeasuredRun &run, const Signals &model,
                                               const std::map<std::string, double> &scales,
                                               std::size_t from = 0);

  /// One signal's residual (model - data) in shape: its size, where in
  /// the cycle and the record it lies, at which harmonics, and the swing
  /// per cycle of data and model (words.h: shape_words).
  struct SignalShape
  {
    double                rms_normalised = 0; ///< over its scale
    double                rms  = 0;           ///< in the signal's unit
    double                bias = 0;           ///< mean of model - data
    std::array<double, 2> half_fraction{};    ///< of its energy in the pressurising stroke, the refill
    /// over the second half's whole cycles: mean (0) and harmonics 1..10
    std::vector<double>   harmonic_amplitudes;
    int                   dominant_harmonic = 1;
    double                above_10th = 0;     ///< share of its energy above the 10th harmonic
    std::array<double, 3> rms_by_third{};     ///< RMS in each third of the record
    double                swing_data = 0, swing_model = 0; ///< mean max - min per cycle
  };

  /// One run's residual described, signal by signal.
  struct Localisation
  {
    std::map<std::string, SignalShape> signals;
    std::string              dominant_signal; ///< largest normalised residual
    std::string              dominant_half;   ///< "pressurising" or "refill"
    nlohmann::json           numbers() const; ///< summary.json's
  };
  Localisation localise(const MeasuredRun &run, const Signals &model, double frequency_Hz,
                        const std::map<std::string, double> &scales);

  /// What a model leaves, signal by signal, in the units the verdict
  /// counts: each signal's RMS residual in units of its noise (`noise`,
  /// from sample `from` on), its shape as localise() finds it with
  /// `swings`; the most first. The first is where most of it lies, which is
  /// not the largest share of a swing: a no-flow record's outlet pressure
  /// hardly swings, so a residual within its noise is a large share of it.
  struct SignalResidual
  {
    std::string signal;
    double      noise_units = 0;
    SignalShape shape;
  };
  std::vector<SignalResidual> residuals_in_noise_units(const MeasuredRun &run, const Signals &model,
                                                       double frequency_Hz,
                                                       const std::map<std::string, double> &swings,
                                                       const std::map<std::string, double> &noise, std::size_t from);

  /// Residual energy of `signal` in the given half of the cycle over the
  /// record (for the signature check), normalised.
  double half_cycle_residual(const MeasuredRun &run, const Signals &model, double frequency_Hz,
                             const std::string &signal, const std::string &half,
                             const std::map<std::string, double> &scales);
} // namespace rectify::diagnosis
