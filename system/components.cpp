// The model's components (system/component.h): one line each. Their order
// is the order the model sums their terms in and applies their adjust()s.
#include "system/component.h"

#include <Eigen/Dense>

#include "system/components/coil_dynamics.h"
#include "system/components/free_air.h"
#include "system/components/orifice_flow.h"
#include "system/components/outlet_compliance.h"
#include "system/components/outlet_line.h"
#include "system/components/piston_friction.h"
#include "system/components/valve_leakage.h"
#include "system/components/valve_leakage_turbulent.h"

namespace rectify::system
{
  Components make_components(const SystemParameters &p, Scenario scenario, const ModelConstants &thesis)
  {
    using Factory = std::shared_ptr<const Component> (*)(const SystemParameters &, Scenario, const ModelConstants &);
    static constexpr Factory factories[] = {
      &OutletLine::make, // first: its node takes a tenth of the thesis's high side
      &FreeAir::make,
      &OutletCompliance::make,
      &ValveLeakage::make,
      &ValveLeakageTurbulent::make,
      &OrificeFlow::make,
      &CoilDynamics::make,
      &PistonFriction::make,
    };
    Components on;
    for (const Factory make : factories)
      if (auto c = make(p, scenario, thesis))
        on.push_back(std::move(c));
    return on;
  }

  double OutletLine::ringing_Hz(const ModelConstants &c) const
  {
    // K p = omega^2 C p on the n + 1 nodes (the last the high side), K the
    // chain's stiffness (1 / (L / n) per segment); symmetric as
    // C^-1/2 K C^-1/2, its lowest eigenvalue 0 (all nodes at one pressure).
    const std::size_t n = n_;
    Eigen::VectorXd   C(n + 1);
    for (std::size_t k = 0; k <= n; ++k)
      C(static_cast<Eigen::Index>(k)) = k == 0 ? C_node_ : k == n ? c.C_h : C_between_;
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n + 1), static_cast<Eigen::Index>(n + 1));
    const double    g = static_cast<double>(n) / L_;
    for (Eigen::Index k = 0; k < static_cast<Eigen::Index>(n); ++k)
      {
        const double a = 1.0 / std::sqrt(C(k)), b = 1.0 / std::sqrt(C(k + 1));
        S(k, k) += g * a * a;
        S(k + 1, k + 1) += g * b * b;
        S(k, k + 1) -= g * a * b;
        S(k + 1, k) -= g * a * b;
      }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S, Eigen::EigenvaluesOnly);
    return std::sqrt(std::max(eig.eigenvalues()(1), 0.0)) / (2.0 * M_PI);
  }

  const OutletLine *outlet_line(const ModelConstants &c)
  {
    for (const auto &component : c.components)
      if (const auto *line = dynamic_cast<const OutletLine *>(component.get()))
        return line;
    return nullptr;
  }

  double outlet_line_ringing_Hz(const ModelConstants &c)
  {
    const auto *line = outlet_line(c);
    return line ? line->ringing_Hz(c) : 0.0;
  }
} // namespace rectify::system
