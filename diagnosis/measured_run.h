// A measured time series (one run) as the diagnosis workflow reads it: a CSV
// whose column names carry their units (issue 4).
//   required: time_s, current_A or voltage_V, outlet_pressure_Pa
//   optional: chamber_pressure_Pa, outlet_valve_m, strain,
//             actuator_position_m, actuator_velocity_m_per_s
// Other columns are ignored (listed in ignored_columns, for a notice); a
// known quantity in another unit (time_ms, outlet_pressure_psi, ...) is an
// error that names the unit expected.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace rectify::diagnosis
{
  /// One sample that stands alone far off its neighbours (a spike), found
  /// and replaced by repair_outliers.
  struct Outlier
  {
    std::string column;
    std::size_t row         = 0; ///< data row (1 = the first after the header)
    double      time_s      = 0; ///< from the record's start
    double      size        = 0; ///< its offset from its neighbours' mean, in the column's unit
    double      noise_units = 0; ///< the same over the column's white noise sd
  };

  struct MeasuredRun
  {
    std::string                                source;  ///< the file, for messages
    std::vector<double>                        time_s;
    std::map<std::string, std::vector<double>> signals; ///< by column name, every column read
    std::vector<std::string>                   ignored_columns;

    bool                       has(const std::string &column) const { return signals.count(column) > 0; }
    const std::vector<double> &signal(const std::string &column) const;
    /// "current_A" or "voltage_V": the drive.
    const std::string         &drive_column() const;
    double                     duration_s() const { return time_s.back() - time_s.front(); }

    /// The pumping frequency from the drive: mean-crossings of the drive
    /// (hysteresis 10 % of its range) over the record, refined by least
    /// squares (the frequency of the Fourier series that fits the drive
    /// best, measured_run.cpp); throws InputError
    /// (naming the file) if the drive shows fewer than two cycles.
    double drive_frequency_Hz() const;

    /// Parses and checks: times strictly increasing (unsorted or repeated:
    /// the row and both times named), every value finite, the required
    /// columns present, known quantities in their units, at least 20 rows.
    /// `min_cycles` > 0 with `frequency_Hz` (0: from the drive) also asks
    /// for that many pumping cycles. Throws InputError naming the file, row
    /// and column.
    static MeasuredRun parse(const std::string &text, const std::string &source, double frequency_Hz = 0,
                             double min_cycles = 2);
    static MeasuredRun read(const std::filesystem::path &path, double frequency_Hz = 0, double min_cycles = 2);

    /// Finds isolated spikes in every column (the drive's included) and
    /// replaces each by the mean of its two neighbours. A spike is a sample
    /// whose offset from its neighbours' mean, d_k = x_k - (x_{k-1} + x_{k+1}) / 2,
    /// exceeds `threshold` standard deviations of d for the column's white
    /// noise (sd(d) = sqrt(1.5) sd), with both neighbours' offsets of the
    /// opposite sign and a quarter to three quarters of its size (the
    /// pattern one displaced sample leaves; a kink or a step does not). A
    /// spike that recurs at the same phase of the pumping cycle (one sample
    /// either way, the same sign, at least half its size) in at least half
    /// of the record's other cycles is the pump's own (a pressure spike at
    /// each valve closing) and is left alone. The cycle is `frequency_Hz`'s
    /// (0: the drive's); a record not uniformly sampled or shorter than two
    /// cycles is not tested for recurrence.
    std::vector<Outlier> repair_outliers(double threshold = 6.0, double frequency_Hz = 0);
  };

  /// The signals a run can carry beside time and drive, in report order.
  const std::vector<std::string> &signal_columns();

  /// Whether the times are evenly spaced (to 1 % of their mean step).
  bool uniformly_sampled(const std::vector<double> &times);
} // namespace rectify::diagnosis
