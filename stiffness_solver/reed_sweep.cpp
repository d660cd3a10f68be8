#include "stiffness_solver/reed_sweep.h"

#include <cmath>
#include <cstdio>
#include <map>

#include "common/checkpoint.h"
#include "common/io.h"
#include "common/progress.h"
#include "stiffness_solver/elasticity.h"
#include "stiffness_solver/reed_analysis.h"

namespace rectify::stiffness
{
  ReedSweepResult reed_thickness_sweep(const StiffnessParameters &base, const std::vector<double> &thicknesses,
                                       const std::filesystem::path &dir)
  {
    for (double t : thicknesses)
      if (!(t > 0) || t >= 0.5 * std::min(base.geometry.reed_length_m, base.geometry.reed_width_m))
        throw InputError("thickness " + format_number(t) + " m: a reed must be a thin plate");
    nlohmann::json fingerprint = {{"thickness_m", thicknesses},
                                        {"reed_length_m", base.geometry.reed_length_m},
                                        {"reed_width_m", base.geometry.reed_width_m},
                                        {"port_diameter_m", base.geometry.port_diameter_m},
                                        {"port_center_x_m", base.geometry.port_center_x_m},
                                        {"youngs_modulus_Pa", base.material.youngs_modulus_Pa},
                                        {"poisson_ratio", base.material.poisson_ratio},
                                        {"density_kg_per_m3", base.material.density_kg_per_m3},
                                        {"fluid_density_kg_per_m3", base.fluid.density_kg_per_m3},
                                        {"load", to_string(base.settings.load)},
                                        {"mesh",
                                         {base.settings.cells_along_length, base.settings.cells_across_width,
                                          base.settings.cells_through_thickness, base.settings.fe_degree}},
                                        {"n_modes", base.settings.n_modes},
                                        {"added_mass_factor", base.settings.added_mass_factor}};
    // An outline's description: two outlines may share the numbers above
    // (their bounding box and first port). The shorthand's fingerprint is kept.
    if (!base.geometry.is_shorthand())
      fingerprint["outline"] = base.geometry.to_json();
    const auto &columns = maps::ReedMap::columns();
    std::string header;
    for (const auto &c : columns)
      header += (header.empty() ? "" : ",") + c;
    fingerprint["columns"] = header; // a checkpoint of an earlier version's columns is refused, not misread
    ensure_directory(dir);
    Checkpoint                            checkpoint(dir, "map-partial", fingerprint, header);
    std::map<double, std::vector<double>> done;
    for (const auto &row : checkpoint.finished_rows())
      {
        const auto csv       = parse_csv(header + "\n" + row + "\n", (dir / "map-partial.csv").string());
        done[csv.rows[0][0]] = csv.rows[0];
      }
    const std::size_t n_resumed = done.size();
    Progress          progress("map-stiffness", thicknesses.size(), n_resumed);
    for (double t : thicknesses)
      {
        if (done.count(t))
          continue;
        auto p                      = base;
        p.geometry.reed_thickness_m = t;
        SolveOptions so;
        so.n_shape_points         = 2;
        const auto    r           = solve_reed(p, so);
        const auto    b           = reed_bounds(p);
        const InFluid fluid       = in_fluid(r, b, p.settings.added_mass_factor);
        const std::vector<double> row{t,
                                      r.k_N_per_m,
                                      r.modes.empty() ? 0.0 : r.modes[0].frequency_Hz,
                                      r.modes.empty() ? 0.0 : r.modes[0].modal_mass_kg,
                                      fluid.frequency_Hz,
                                      fluid.modal_mass_kg,
                                      fluid.eq321_mass_kg,
                                      fluid.eq321_frequency_Hz,
                                      r.root_stress_per_opening_Pa_per_m,
                                      r.root_stress_beam_per_opening_Pa_per_m,
                                      r.root_stress_concentration,
                                      r.second_mode_root_stress_per_opening_Pa_per_m,
                                      static_cast<double>(r.n_dofs),
                                      r.wall_time_s};
        checkpoint.append(csv_row(row));
        done[t] = row;
        char what[192];
        std::snprintf(what, sizeof(what), "t = %.4g m: k = %.5g N/m, f1 = %.5g Hz, root stress %.4g MPa/um, %.1f s", t,
                      r.k_N_per_m, row[2], r.root_stress_per_opening_Pa_per_m * 1e-12, r.wall_time_s);
        progress.step(what);
      }

    std::vector<std::vector<double>> rows;
    for (double t : thicknesses)
      rows.push_back(done.at(t));
    nlohmann::json meta = fingerprint;
    meta["quantity"]    = "reed stiffness, first mode, masses and root stress vs thickness";
    meta["written_by"]  = std::string("rectify ") + RECTIFY_VERSION;
    // log-log slope of k(t) by least squares
    double       sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double n  = static_cast<double>(thicknesses.size());
    for (double t : thicknesses)
      {
        const double x = std::log(t), y = std::log(done.at(t)[1]);
        sx += x, sy += y, sxx += x * x, sxy += x * y;
      }
    const double slope = n > 1 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : 0.0;
    return {maps::ReedMap(columns, std::move(rows), (dir / "reed-map.csv").string(), meta), slope, n_resumed};
  }
} // namespace rectify::stiffness
