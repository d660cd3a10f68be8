// The system model driven by a measured run: simulated at the run's sample
// times, reduced to the signals the run measured (the columns of
// MeasuredRun), so that data and model compare sample by sample.
//
// Where a record starts (StartState): at rest (all pressures at the bias,
// reeds on their seats, the drive from zero), at the static state under the
// record's first drive value, or in the periodic state of its drive (a
// run-in of whole cycles before the record). The record's first time is
// t = 0. Pressures are absolute [Pa]; `strain` is the piston (rod end)
// displacement over the rod length.
#pragma once

#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "diagnosis/measured_run.h"
#include "maps/resistance_map.h"
#include "system/model.h"
#include "system/parameters.h"

namespace rectify::diagnosis
{
  /// One run as the workflow simulates it.
  struct RunSetup
  {
    system::Scenario scenario     = system::Scenario::no_flow;
    double           frequency_Hz = 0; ///< pumping frequency (from the drive unless given)
  };

  /// The state a record starts from (issue 17): a measured record rarely
  /// starts at rest.
  enum class StartState
  {
    rest,     ///< the model from rest at t = 0 (a synthetic run, a pump switched on)
    steady,   ///< the static state under the drive's first value, held before the record
    periodic, ///< the periodic state: the record's first cycle repeated before it (a run-in)
    record,   ///< the state the record shows at its first sample (recorded_state), no run-in
    /// As record, but the high side (and an outlet line) at the outlet
    /// pressure's mean over the record's first cycle: in a no-flow run the
    /// high side is closed, its pressure holds while the outlet valve is
    /// shut and a line's mean drop over a periodic cycle is nil, while at
    /// one instant a line's ringing can put the outlet pressure a tenth of
    /// a MPa off the high side's, an error in the oil stored there that no
    /// later cycle undoes (without a leak the outlet valve only adds oil).
    record_mean
  };
  std::string to_string(StartState s);
  /// A start read off the record (record, record-mean): no run-in before it.
  inline bool from_record(StartState s) { return s == StartState::record || s == StartState::record_mean; }
  /// "rest", "steady", "periodic", "record", "record-mean"; InputError otherwise.
  StartState start_state_from_string(const std::string &name);

  /// What a record says about the state at its first sample: each measured
  /// signal's value there within the first drive_cutoff_harmonic harmonics
  /// (band_limit: the noise averaged out over about a twentieth of a cycle);
  /// NaN where the record lacks the signal.
  struct RecordedState
  {
    double chamber_pressure_Pa       = std::numeric_limits<double>::quiet_NaN();
    double outlet_pressure_Pa        = std::numeric_limits<double>::quiet_NaN();
    /// The outlet pressure's mean over the record's first cycle (NaN if
    /// the record is shorter)
    double outlet_pressure_mean_Pa   = std::numeric_limits<double>::quiet_NaN();
    /// StartState::record_mean: the high side starts at that mean
    bool   high_side_at_mean         = false;
    double outlet_valve_m            = std::numeric_limits<double>::quiet_NaN();
    double outlet_valve_noise_m      = 0; ///< the opening's white-noise sd (is it open?)
    double strain                    = std::numeric_limits<double>::quiet_NaN();
    double actuator_position_m       = std::numeric_limits<double>::quiet_NaN();
    double actuator_velocity_m_per_s = std::numeric_limits<double>::quiet_NaN();
  };
  RecordedState recorded_state(const MeasuredRun &run, double frequency_Hz);

  struct SimulationOptions
  {
    StartState  start       = StartState::rest;
    double      lead_cycles = 0; ///< cycles simulated before the record (steady, periodic)
    double      relative_tolerance = 1e-6;
    std::size_t n_samples          = 0; ///< simulate only the first n samples (0: all)
    double      drive_noise_sd     = 0; ///< add white noise of this sd to the drive (before its filter)
    double      band_Hz            = 0; ///< > 0: every output signal band_limit()ed at this frequency
    unsigned long seed             = 1; ///< of that noise
    /// The model's actuator position shifted by the mean of (data - model):
    /// a position sensor's zero is arbitrary, and a record that starts
    /// mid-operation starts wherever the piston has travelled to. The
    /// position is a pure integral of the velocity (the load has no spring
    /// in the thesis's cases), so this is the initial position fitted in
    /// closed form.
    bool position_offset = true;
    /// For StartState::record: the record's state, if already read (once
    /// per run: RunCase); read from the run otherwise.
    std::optional<RecordedState> recorded;
    /// The run's cleaned drive, measured_drive(run, frequency), if already
    /// made (once per run: RunCase); made from the run otherwise, and
    /// always with drive_noise_sd > 0. Cleaning it (a Fourier fit and a
    /// cosine transform of the record's length) was a tenth of a run.
    std::shared_ptr<const system::Drive> drive;
  };

  using Signals = std::map<std::string, std::vector<double>>;


  /// The model's state at a record's first sample (StartState::record):
  /// chamber and outlet pressures (the high side, and the outlet line's nodes
  /// when there is one, at the outlet pressure, or at its first cycle's
  /// mean where r.high_side_at_mean), the rod from the strain
  /// (else from its static balance under the drive), the chamber's oil
  /// column in its static balance, the outlet reed at its measured opening
  /// (open, if it stands above its noise), the output piston where and as
  /// fast as measured, and the accumulator and low side where the circuit's
  /// oil volume, conserved since rest, puts them. What the record does not
  /// show (reed and piston velocities, the inlet reed, a line's flow) starts
  /// at rest and settles within the first cycle, which the residuals skip;
  /// a voltage-driven coil with inductance starts at its periodic current
  /// (periodic_coil_current).
  /// Sets the model's valve states to match.
  std::vector<double> state_from_record(system::Model &model, const RecordedState &r, double drive_at_0,
                                        double rod_length_m);

  /// The current at t = 0 of a coil (resistance R, inductance L) in
  /// periodic operation under `drive`'s voltage, its first cycle repeated:
  /// what a record that starts mid-operation has in its coil.
  double periodic_coil_current(const system::Drive &drive, double R, double L);

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

  /// Spectral hard threshold (Donoho and Johnstone's universal threshold):
  /// the cosine-series coefficients of uniformly sampled values (the record
  /// mirrored at its ends) are kept where they stand above
  /// noise_sd sqrt(2 ln n) in units of white noise of sd `noise_sd`, the rest
  /// set to zero. Returns the values unchanged if the sampling is not uniform
  /// or noise_sd is not positive.
  std::vector<double> spectral_threshold(const std::vector<double> &times,
                                         const std::vector<double> &values, double noise_sd);

  /// The record's content below `cutoff_Hz`, exactly: the cosine series of
  /// the record (mirrored at its ends, so no wrap-around jump) with every
  /// term above the cutoff removed. Zero phase; the same operation on data
  /// and model compares them within the band. Unchanged if not uniformly
  /// sampled or the cutoff is at or above the Nyquist frequency.
  std::vector<double> band_limit(const std::vector<double> &times, const std::vector<double> &values,
                                 double cutoff_Hz);

  /// A measured periodic drive without its noise: a least-squares Fourier
  /// series in the harmonics of `frequency_Hz` up to `max_harmonic`, each
  /// harmonic kept only if its amplitude stands above the universal
  /// threshold for white noise of sd `noise_sd`, plus what is not periodic
  /// in the record (a start, a drift) through spectral_threshold. Of the
  /// noise only what falls on the kept harmonics is left (a few parts in
  /// n), where a low-pass at the 10th harmonic keeps a tenth of its power
  /// at 200 samples a cycle. Unchanged if not uniformly sampled or noise_sd
  /// is not positive.
  std::vector<double> denoise_periodic(const std::vector<double> &times,
                                       const std::vector<double> &values, double frequency_Hz,
                                       int max_harmonic, double noise_sd);

  /// The drive of `run` for the model (its time origin moved to 0; its
  /// measurement noise, estimated from its second differences, removed by
  /// denoise_periodic; low-passed at drive_cutoff_harmonic x the pumping
  /// frequency).
  system::Drive measured_drive(const MeasuredRun &run, double frequency_Hz,
                               double extra_noise_sd = 0, unsigned long seed = 1);
  /// The same drive with `lead_cycles` cycles before t = 0 for a start
  /// other than rest: from 0 it rises (raised cosine, one cycle) to the
  /// drive's first value and holds it (steady), or to the record's first
  /// cycle repeated (periodic).
  system::Drive measured_drive(const MeasuredRun &run, double frequency_Hz, double extra_noise_sd,
                               unsigned long seed, StartState start, double lead_cycles);
  /// The same from the run's cleaned drive `cleaned` (measured_drive(run, frequency_Hz, ...)).
  system::Drive with_lead(system::Drive cleaned, const MeasuredRun &run, double frequency_Hz, StartState start,
                          double lead_cycles);

  /// Simulates `run` with parameters `p` and returns every signal of
  /// signal_columns() that the run has, at its sample times. Throws
  /// std::runtime_error if the integrator fails.
  Signals simulate_run(const system::SystemParameters &p, const system::ValveMaps &map,
                       const MeasuredRun &run, const RunSetup &setup,
                       const SimulationOptions &options = {});

  /// The same from a drive and times directly (the synthesiser), every
  /// signal of signal_columns() (actuator signals only when loaded).
  Signals simulate_drive(const system::SystemParameters &p, const system::ValveMaps &map,
                         const system::Drive &drive, system::Scenario scenario,
                         const std::vector<double> &times, double relative_tolerance,
                         double t_start = 0.0, const RecordedState *from = nullptr);
} // namespace rectify::diagnosis
