#include "diagnosis/uncertainty.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace rectify::diagnosis
{
  Eigen::MatrixXd covariance(const Eigen::MatrixXd &F)
  {
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(F);
      Eigen::VectorXd                                inv = eig.eigenvalues();
      const double                                   top = std::max(inv.maxCoeff(), 1e-300);
      for (Eigen::Index k = 0; k < inv.size(); ++k)
        inv(k) = inv(k) > 1e-12 * top ? 1.0 / inv(k) : std::numeric_limits<double>::infinity();
      Eigen::MatrixXd C = Eigen::MatrixXd::Zero(F.rows(), F.cols());
      for (Eigen::Index k = 0; k < inv.size(); ++k)
        if (std::isinf(inv(k)))
          {
            // only the entries the null direction touches become infinite
            const Eigen::VectorXd v = eig.eigenvectors().col(k);
            for (Eigen::Index i = 0; i < v.size(); ++i)
              for (Eigen::Index j = 0; j < v.size(); ++j)
                if (std::abs(v(i) * v(j)) > 1e-12)
                  C(i, j) = std::numeric_limits<double>::infinity();
          }
        else
          C += inv(k) * eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose();
      return C;
  }

  Eigen::MatrixXd fit_information(const Eigen::MatrixXd &J, double s2, const Eigen::VectorXd &prior_precision)
  {
    if (prior_precision.size() != J.cols())
      throw std::invalid_argument("fit_information: " + std::to_string(prior_precision.size()) + " priors for " +
                                  std::to_string(J.cols()) + " parameters");
    if (!(s2 > 0))
      throw std::invalid_argument("fit_information: the residual's variance must be > 0");
    Eigen::MatrixXd F = J.transpose() * J / s2;
    F.diagonal() += prior_precision;
    return F;
  }

  double propagated_variance(const Eigen::MatrixXd &covariance, const Eigen::VectorXd &gradient)
  {
    if (gradient.size() != covariance.rows())
      throw std::invalid_argument("propagated_variance: gradient and covariance differ in size");
    double v = 0;
    for (Eigen::Index i = 0; i < gradient.size(); ++i)
      for (Eigen::Index j = 0; j < gradient.size(); ++j)
        if (gradient(i) != 0 && gradient(j) != 0)
          v += gradient(i) * covariance(i, j) * gradient(j);
    return v;
  }
} // namespace rectify::diagnosis
