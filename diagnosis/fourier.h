// A Fourier series in the harmonics of one frequency, as a least-squares
// design matrix over sample times (the drive's frequency refinement and its
// cleaning, measured_run.cpp and observation.cpp).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <vector>

namespace rectify::diagnosis
{
  /// Columns: 1, then cos and sin of 2 pi k f (t - t_0) for k = 1..K.
  inline Eigen::MatrixXd fourier_basis(const std::vector<double> &times, double frequency_Hz, int K)
  {
    Eigen::MatrixXd A(static_cast<Eigen::Index>(times.size()), 2 * K + 1);
    for (std::size_t i = 0; i < times.size(); ++i)
      {
        const auto r = static_cast<Eigen::Index>(i);
        A(r, 0)      = 1.0;
        for (int k = 1; k <= K; ++k)
          {
            const double phase = 2 * std::numbers::pi * k * frequency_Hz * (times[i] - times.front());
            A(r, 2 * k - 1)    = std::cos(phase);
            A(r, 2 * k)        = std::sin(phase);
          }
      }
    return A;
  }
} // namespace rectify::diagnosis
