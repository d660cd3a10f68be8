#include "system/drive.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/case_file.h"
#include "common/io.h"

namespace rectify::system
{
  Drive Drive::sine(double frequency_Hz, double current_pp_A, double current_bias_A)
  {
    if (!(frequency_Hz > 0) || !std::isfinite(frequency_Hz))
      throw InputError("pumping frequency " + format_number(frequency_Hz) +
                       " Hz: must be > 0");
    if (!(current_pp_A >= 0) || !std::isfinite(current_pp_A) || !std::isfinite(current_bias_A))
      throw InputError("drive current: peak-to-peak " + format_number(current_pp_A) +
                       " A, bias " + format_number(current_bias_A) +
                       " A: must be finite, peak-to-peak >= 0");
    Drive d;
    d.frequency_ = frequency_Hz;
    d.pp_        = current_pp_A;
    d.bias_      = current_bias_A;
    d.source_    = "sine";
    return d;
  }

  Drive Drive::from_csv(const std::filesystem::path &path, double frequency_Hz)
  {
    Drive d       = sine(frequency_Hz, 0.0, 0.0);
    d.source_     = path.string();
    const auto csv = read_csv(path);
    const auto ct  = csv.column_index("time_s", path.string());
    const auto ci  = csv.column_index("current_A", path.string());
    if (csv.rows.size() < 2)
      throw InputError("drive waveform '" + path.string() + "': needs at least two rows");
    for (std::size_t r = 0; r < csv.rows.size(); ++r)
      {
        const double t = csv.rows[r][ct];
        if (r > 0 && !(t > d.times_.back()))
          throw InputError("drive waveform '" + path.string() + "' data row " +
                           std::to_string(r + 1) + ", column 'time_s': " + format_number(t) +
                           " does not increase");
        d.times_.push_back(t);
        d.currents_.push_back(csv.rows[r][ci]);
      }
    return d;
  }

  Drive Drive::from_samples(std::vector<double> times_s, std::vector<double> values,
                            double frequency_Hz, bool voltage, std::string source)
  {
    Drive d = sine(frequency_Hz, 0.0, 0.0);
    if (times_s.size() != values.size() || times_s.size() < 2)
      throw InputError("drive record '" + source + "': needs at least two samples, one value per time");
    for (std::size_t i = 1; i < times_s.size(); ++i)
      if (!(times_s[i] > times_s[i - 1]))
        throw InputError("drive record '" + source + "': times do not increase at sample " +
                         std::to_string(i + 1));
    d.times_    = std::move(times_s);
    d.currents_ = std::move(values);
    d.voltage_  = voltage;
    d.source_   = std::move(source);
    return d;
  }

  double Drive::value(double t) const
  {
    if (times_.empty())
      return bias_ - 0.5 * pp_ * std::cos(2.0 * std::numbers::pi * frequency_ * t);
    if (t <= times_.front())
      return currents_.front();
    if (t >= times_.back())
      return currents_.back();
    const std::size_t hint = last_.segment.load(std::memory_order_relaxed);
    std::size_t       i    = hint < times_.size() - 1 ? hint : 0;
    if (!(times_[i] <= t && t < times_[i + 1]))
      {
        if (i + 2 < times_.size() && times_[i + 1] <= t && t < times_[i + 2])
          ++i;
        else
          i = static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), t) -
                                       times_.begin()) - 1;
        last_.segment.store(i, std::memory_order_relaxed);
      }
    const double s  = (t - times_[i]) / (times_[i + 1] - times_[i]);
    return currents_[i] + s * (currents_[i + 1] - currents_[i]);
  }

  void Drive::check_covers(double t_end) const
  {
    if (times_.empty())
      return;
    if (times_.front() > 0.0 || times_.back() < t_end)
      throw InputError("drive waveform '" + source_ + "' covers t = " +
                       format_number(times_.front()) + " .. " + format_number(times_.back()) +
                       " s, but the run needs 0 .. " + format_number(t_end) + " s");
  }
} // namespace rectify::system
