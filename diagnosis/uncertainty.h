// How well a fit determines its parameters (issue 17): the Gauss-Newton
// covariance of a least-squares fit in [0, 1] positions, with the bounded
// parameters' ranges as a prior, and what it says about one parameter or a
// function of several. diagnose.cpp uses it for the named effect's
// parameters at its final fit, the baseline's uncertain parameters counted
// as unknown within their ranges.
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace rectify::diagnosis
{
  /// A uniform prior over a [0, 1] position has variance 1/12: its precision.
  inline constexpr double uniform_prior_precision = 12.0;

  /// The information of a least-squares fit in [0, 1] positions: J^T J / s2
  /// + diag(prior_precision), J the residual's Jacobian, s2 the residual's
  /// variance per independent value. Throws std::invalid_argument on
  /// mismatched sizes or s2 <= 0.
  Eigen::MatrixXd fit_information(const Eigen::MatrixXd &J, double s2, const Eigen::VectorXd &prior_precision);

  /// The covariance, the information's inverse. A direction with no
  /// information (no data and no prior) gets infinite variance in the
  /// entries it touches. The first k parameters' covariance with the others
  /// held where they are is covariance(F.topLeftCorner(k, k)).
  Eigen::MatrixXd covariance(const Eigen::MatrixXd &information);

  /// The variance of f(u) at the fit for a function with gradient g (delta
  /// method): g^T C g.
  double propagated_variance(const Eigen::MatrixXd &covariance, const Eigen::VectorXd &gradient);
} // namespace rectify::diagnosis
