// The measuring chain between the rig and a record: each signal passes a
// sensor (a pressure transducer, the valve's laser, the strain gauge's
// amplifier) that lags it. A first-order lag of bandwidth f_c (-3 dB) stands
// for each; at the pumping frequency f it delays the signal by about
// 1 / (2 pi f_c) and turns its first harmonic by atan(f / f_c): a 5 kHz
// transducer on a 150 Hz pressure is 1.7 deg, 3 % of its swing. A model with
// ideal sensors then leaves that much residual however right its physics.
//
// After a diagnosis has chosen its model, calibrate_sensor_lags fits each
// signal's bandwidth, between the case's lowest ([sensors]) and an ideal
// sensor, to the final model's signals on the training part of the records
// (one bandwidth per signal, shared by every run), and applies it. It needs
// no run of the model: the lag acts on the model's output. Nothing the
// diagnosis decides or fits depends on it; only the residual it reports.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/case_file.h"
#include "diagnosis/results.h"
#include "diagnosis/runs.h"

namespace rectify::diagnosis
{
  /// The lowest bandwidth [Hz] of each kind of sensor ([sensors] in a case:
  /// pressure, opening, strain, actuator; 0: ideal, not fitted).
  struct SensorLimits
  {
    double pressure_Hz = 0, opening_Hz = 0, strain_Hz = 0, actuator_Hz = 0;
    static SensorLimits from_case(const CaseFile &file);
    /// Per measured signal (signal_columns()): its sensor's lowest bandwidth, where > 0.
    std::map<std::string, double> per_signal() const;
  };

  /// `values` sampled at `times` (uniformly, or not) through a first-order lag
  /// tau y' = x - y with tau = 1 / (2 pi bandwidth_Hz), exact for an input
  /// linear between samples, starting at y = x. An infinite bandwidth
  /// returns the values.
  std::vector<double> first_order_lag(const std::vector<double> &times, const std::vector<double> &values,
                                      double bandwidth_Hz);

  /// Fits each signal's lag (SensorLimits::per_signal; signals without a
  /// bound stay ideal) to `model` (per run, the model's signals over the
  /// whole record), minimising the signal's squared residual in noise units
  /// over every run's training samples [n_skip, n_train) (a scan of 24
  /// delays from 0 to the bound's, then a golden-section search around the
  /// best), and applies it to `model` in place where the held-out samples
  /// (from n_train on) fit at least as well with it as without.
  std::vector<SensorLag> calibrate_sensor_lags(const std::vector<RunCase> &runs, std::vector<Signals> &model,
                                               const std::map<std::string, double> &lowest_bandwidth_Hz);
} // namespace rectify::diagnosis
