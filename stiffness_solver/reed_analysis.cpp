#include "stiffness_solver/reed_analysis.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "stiffness_solver/analytic.h"

namespace rectify::stiffness
{
  ReedBounds reed_bounds(const StiffnessParameters &p)
  {
    const auto  &g  = p.geometry;
    // An outline's bounds are those of a rectangle of its length and mean width.
    const double W  = g.is_shorthand() ? g.reed_width_m : g.reed_area_m2() / g.reed_length_m;
    const double I  = analytic::second_moment(W, g.reed_thickness_m);
    const double E  = p.material.youngs_modulus_Pa;
    const double Ep = analytic::plate_modulus(E, p.material.poisson_ratio);
    const auto compliance = [&](double EI) {
      switch (p.settings.load)
        {
          case Load::tip_line:
            return analytic::tip_load_compliance(EI, g.reed_length_m);
          case Load::uniform_pressure:
            return analytic::uniform_load_compliance(EI, g.reed_length_m);
          default:
            return analytic::port_load_compliance(EI, g.reed_length_m, g.port_center_x_m, 0.5 * g.port_diameter_m);
        }
    };
    const double m_per_length = p.material.density_kg_per_m3 * W * g.reed_thickness_m;
    return {1.0 / compliance(E * I), 1.0 / compliance(Ep * I),
            analytic::first_frequency_Hz(E * I, m_per_length, g.reed_length_m),
            analytic::first_frequency_Hz(Ep * I, m_per_length, g.reed_length_m),
            analytic::added_mass_kg(p.fluid.density_kg_per_m3, g.reed_length_m, W)};
  }

  InFluid in_fluid(const StiffnessResult &r, const ReedBounds &b, double factor)
  {
    InFluid out{0, 0, 0, 0};
    if (!r.modes.empty() && r.modes[0].modal_mass_kg > 0)
      {
        const double scale = analytic::added_mass_scale(r.plate_mass_kg, b.added_mass_kg);
        out.modal_mass_kg  = r.modes[0].modal_mass_kg * scale;
        out.frequency_Hz   = r.modes[0].frequency_Hz / std::sqrt(scale);
      }
    out.eq321_mass_kg      = factor * (r.plate_mass_kg + b.added_mass_kg);
    out.eq321_frequency_Hz = std::sqrt(r.k_N_per_m / out.eq321_mass_kg) / (2 * M_PI);
    return out;
  }

  std::string shape_csv(const StiffnessResult &r, const StiffnessParameters &p)
  {
    const nlohmann::json meta = {
      {"quantity", "reed underside deflection / mean tip deflection"},
      {"load", to_string(p.settings.load)},
      {"reed_length_m", p.geometry.reed_length_m},
      {"reed_width_m", p.geometry.reed_width_m},
      {"reed_thickness_m", p.geometry.reed_thickness_m},
      {"columns", "s_m: distance from the clamp line; phi: mean across the width; phi_centerline: at y = 0"},
      {"written_by", std::string("rectify ") + RECTIFY_VERSION}};
    std::ostringstream s;
    s << "# rectify reed shape (\"fe\"): z = tip_opening * phi(s)\n# meta: " << meta.dump()
      << "\ns_m,phi,phi_centerline\n";
    char buf[96];
    for (std::size_t i = 0; i < r.shape_s_m.size(); ++i)
      {
        std::snprintf(buf, sizeof(buf), "%.17g,%.17g,%.17g\n", r.shape_s_m[i], r.shape_phi[i],
                      r.shape_phi_centerline[i]);
        s << buf;
      }
    return s.str();
  }

  double beam_shape(double x, double L, double a)
  {
    return x <= a ? x * x * (3 * a - x) / (a * a * (3 * L - a)) : (3 * x - a) / (3 * L - a);
  }
} // namespace rectify::stiffness
