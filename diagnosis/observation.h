// The system model driven by a measured run: simulated at the run's sample
// times, reduced to the signals the run measured (the columns of
// MeasuredRun), so that data and model compare sample by sample.
//
// A run starts at rest: all pressures at the bias, reeds on their seats, at
// the record's first time (taken as t = 0). Pressures are absolute [Pa];
// `strain` is the piston (rod end) displacement over the rod length.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "diagnosis/measured_run.h"
#include "maps/resistance_map.h"
#include "system/model.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  /// The signals a run can carry beside time and drive, in report order.
  const std::vector<std::string> &signal_columns();

  /// One run as the workflow simulates it.
  struct RunSetup
  {
    system::Scenario scenario     = system::Scenario::no_flow;
    double           frequency_Hz = 0; ///< pumping frequency (from the drive unless given)
  };

  struct SimulationOptions
  {
    double      relative_tolerance = 1e-6;
    std::size_t n_samples          = 0; ///< simulate only the first n samples (0: all)
    double      drive_noise_sd     = 0; ///< add white noise of this sd to the drive (before its filter)
    unsigned long seed             = 1; ///< of that noise
  };

  using Signals = std::map<std::string, std::vector<double>>;

  /// The measured drive is low-passed at this harmonic of the pumping
  /// frequency before it drives the model: its measurement noise would
  /// otherwise shake the rod at every frequency (the transducer resonates
  /// near 2.9 kHz) and put the noise's response into every residual.
  inline constexpr double drive_cutoff_harmonic = 10.0;

  /// Zero-phase windowed-sinc (Blackman) low-pass of uniformly sampled
  /// values (kernel +-3 cutoff periods, the record mirrored at its ends); returns
  /// the values unchanged if the sampling is not uniform or the cutoff is
  /// near the Nyquist frequency.
  std::vector<double> low_pass(const std::vector<double> &times, const std::vector<double> &values,
                               double cutoff_Hz);

  /// The drive of `run` for the model (its time origin moved to 0, low-passed
  /// at drive_cutoff_harmonic x the pumping frequency).
  system::Drive measured_drive(const MeasuredRun &run, double frequency_Hz,
                               double extra_noise_sd = 0, unsigned long seed = 1);

  /// Simulates `run` with parameters `p` and returns every signal of
  /// signal_columns() that the run has, at its sample times. Throws
  /// std::runtime_error if the integrator fails.
  Signals simulate_run(const system::SystemParameters &p, const maps::ResistanceMap &map,
                       const MeasuredRun &run, const RunSetup &setup,
                       const SimulationOptions &options = {});

  /// The same from a drive and times directly (the synthesiser), every
  /// signal of signal_columns() (actuator signals only when loaded).
  Signals simulate_drive(const system::SystemParameters &p, const maps::ResistanceMap &map,
                         const system::Drive &drive, system::Scenario scenario,
                         const std::vector<double> &times, double relative_tolerance);
} // namespace rectify::diagnosis
