// The coil current I(t) driving the Terfenol-D rod.
#pragma once

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

    double current_A(double t) const;
    double frequency_Hz() const { return frequency_; }
    /// Throws InputError if the waveform does not cover [0, t_end].
    void check_covers(double t_end) const;

  private:
    double              frequency_ = 0, pp_ = 0, bias_ = 0;
    std::vector<double> times_, currents_; // empty for the sine
    std::string         source_;
  };
} // namespace rectify::system
