// The drive of the Terfenol-D rod: the coil current I(t), or the coil voltage
// V(t) (a measured record), which the model turns into a current.
#pragma once

#include <atomic>
#include <filesystem>
#include <vector>

namespace rectify::system
{
  class Drive
  {
  public:
    /// I(t) = bias - (pp/2) cos(2 pi f t): a sine of peak-to-peak `pp` about
    /// `bias`, phased to start at its minimum so that a run starts smoothly
    /// (the piston motion of eq. 3.37 has the same phase).
    static Drive sine(double frequency_Hz, double current_pp_A, double current_bias_A);
    /// A measured or designed waveform: CSV with columns time_s, current_A,
    /// strictly increasing times; linear interpolation between rows. Runs
    /// must end within the table (checked by `check_covers`).
    static Drive from_csv(const std::filesystem::path &path, double frequency_Hz);
    /// A sampled record (times strictly increasing, the same length as
    /// `values`): coil current [A], or coil voltage [V] if `voltage`.
    static Drive from_samples(std::vector<double> times_s, std::vector<double> values,
                              double frequency_Hz, bool voltage, std::string source);

    /// The drive's value at t: current [A], or voltage [V] for a voltage drive.
    double value(double t) const;
    double current_A(double t) const { return value(t); }
    bool   is_voltage() const { return voltage_; }
    double frequency_Hz() const { return frequency_; }
    /// Throws InputError if the waveform does not cover [0, t_end].
    void check_covers(double t_end) const;

  private:
    double              frequency_ = 0, pp_ = 0, bias_ = 0;
    std::vector<double> times_, currents_; // empty for the sine
    std::string         source_;
    bool                voltage_ = false;
    /// The segment of the last lookup (runs look up increasing times): a
    /// hint, shared by the threads that simulate with one drive at once;
    /// any value is a valid start, so relaxed.
    struct Hint
    {
      std::atomic<std::size_t> segment{0};
      Hint() = default;
      Hint(const Hint &o)
        : segment(o.segment.load(std::memory_order_relaxed))
      {}
      Hint &operator=(const Hint &o)
      {
        segment.store(o.segment.load(std::memory_order_relaxed), std::memory_order_relaxed);
        return *this;
      }
    };
    mutable Hint last_;
  };
} // namespace rectify::system
