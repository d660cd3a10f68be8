// `rectify mesh`: the reed valve's fluid domain at one tip opening (mesher/).
#include <cstdio>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/version.h"
#include "common/plot.h"
#include "mesher/mesher.h"
#include "mesher/writers.h"

namespace rectify::app
{
  namespace
  {
    struct MeshOptions
    {
      std::string case_path;
      std::string out_dir;
      std::string opening;
      bool        no_files = false;
    };

    /// section.png: the mesh cut by the plane y = 0 (just off it, so that no
    /// vertex lies on the plane): the whole domain, the layered slab, the gap.
    void plot_section(const mesher::TetMesh &mesh, const mesher::MeshParameters &p, double opening,
                      const std::filesystem::path &out)
    {
      const auto   segments = mesher::section(mesh, 1.234567e-3 * p.geometry.reed_width_m);
      const double slab_top = opening + p.geometry.reed_thickness_m + p.slab_margin_at(opening);
      const auto   write = [&](const std::string &name, double x_max, double z_min, double z_max) {
        // Blocks separated by blank lines, each one segment; its first point is
        // written twice (the plot skips the first row of a block: the header).
        std::string text = "x_mm,z_mm\n";
        char        buf[128];
        for (const auto &s : segments)
          if (std::max(s.x0, s.x1) <= x_max && std::min(s.z0, s.z1) >= z_min && std::max(s.z0, s.z1) <= z_max)
            {
              std::snprintf(buf, sizeof(buf), "%.9g,%.9g\n%.9g,%.9g\n%.9g,%.9g\n\n", s.x0 * 1e3, s.z0 * 1e3,
                            s.x0 * 1e3, s.z0 * 1e3, s.x1 * 1e3, s.z1 * 1e3);
              text += buf;
            }
        write_file_atomic(out / name, text);
      };
      const double big = 1e9;
      write("section_all.csv", big, -big, big);
      write("section_slab.csv", p.geometry.reed_length_m + 0.5e-3, -1e-12, slab_top * (1 + 1e-9));
      write("section_gap.csv", p.geometry.reed_length_m + 0.2e-3, -1e-12, opening * (1 + 1e-9));
      auto series = [&](const std::string &file, double z_scale) {
        return PlotSeries{out / file, "x_mm", "z_mm", "cells cut at y = 0", "lines", 1.0, z_scale};
      };
      render_plot(out / "section",
                  {{"mesh section at y = 0: port, layered slab, TetGen's pocket", "x [mm]", "z [mm]", false,
                    false, {series("section_all.csv", 1.0)}},
                   {"the layered slab: gap, reed (empty), above", "x [mm]", "z [mm]", false, false,
                    {series("section_slab.csv", 1.0)}},
                   {"the gap under the reed", "x [mm]", "z [um]", false, false,
                    {series("section_gap.csv", 1e3)}}});
    }

    void mesh_command(const MeshOptions &o)
    {
      const CaseFile file    = load_case(o.case_path);
      const auto     p       = mesher::MeshParameters::from_case(file);
      const double   opening = mesher::parse_length(o.opening, "--opening");
      const auto    &s       = p.settings;
      echo_settings("mesh", {{"case", o.case_path},
                             {"tip opening [m]", format_number(opening)},
                             {"reed shape", s.shape == "table" ? s.shape_table.string() : "beam"},
                             {"size reed/far [m]", format_number(s.size_reed_m) + " / " +
                                                     format_number(s.size_far_m)},
                             {"layers gap/reed/above", std::to_string(s.gap_layers) + " / " +
                                                         std::to_string(s.reed_layers) + " / " +
                                                         std::to_string(s.above_layers)},
                             {"output", o.out_dir}});
      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock;
      lock.acquire_if_exists(out);
      const auto      result = mesher::mesh_valve(p, opening, true);
      lock.acquire(out); // only now: bad input leaves no output folder
      const auto     &info   = result.info;
      nlohmann::json  summary = mesher::to_json(info);
      summary["command"]         = "mesh";
      summary["rectify_version"] = RECTIFY_VERSION;
      summary["build"] = build_info();
      summary["case"]            = o.case_path;
      summary["boundary_ids"]    = {{"1", "inlet"}, {"2", "outlet"}, {"3", "walls"}, {"4", "reed"}};
      if (!o.no_files)
        {
          mesher::write_vtu(out / "mesh.vtu", result.mesh);
          mesher::write_boundary_vtu(out / "boundary.vtu", result.mesh);
          mesher::write_msh(out / "mesh.msh", result.mesh);
          summary["files"] = {"mesh.vtu", "boundary.vtu", "mesh.msh", "quality.txt", "section.png"};
        }
      write_file_atomic(out / "quality.txt", mesher::quality_report(info.quality));
      if (!o.no_files)
        plot_section(result.mesh, p, opening, out);
      write_json(out / "summary.json", summary);
      std::printf("opening %s m: %zu cells, %zu vertices (gap %zu, bulk %zu); volume %.9e m^3 "
                  "(exact %.9e, rel. error %.1e); min dihedral %.3g deg (bulk %.3g); %.2f s\n",
                  format_number(opening).c_str(), info.quality.all.n_cells, info.n_vertices,
                  info.quality.region[mesher::gap].n_cells, info.quality.region[mesher::bulk].n_cells,
                  info.fluid_volume_m3, info.exact_fluid_volume_m3,
                  (info.fluid_volume_m3 - info.exact_fluid_volume_m3) / info.exact_fluid_volume_m3,
                  info.quality.all.min_dihedral_deg, info.quality.region[mesher::bulk].min_dihedral_deg,
                  info.wall_time_s);
      std::printf("gap treated as closed up to %.4g mm from the clamp (thinner than %.3g um); "
                  "results in %s\n",
                  info.closed_to_m * 1e3, info.cutoff_thickness_m * 1e6, out.c_str());
    }
  } // namespace

  void register_mesh_commands(CLI::App &app)
  {
    auto  o   = std::make_shared<MeshOptions>();
    auto *cmd = app.add_subcommand(
      "mesh", "Mesh the valve's fluid domain at one tip opening: VTU, Gmsh .msh, quality report.\n"
              "Example: rectify mesh --opening 100um --out runs/mesh100");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->add_option("--opening", o->opening, "tip opening: metres, or with a unit (2e-6, 100um, 1.21mm)")
      ->required();
    cmd->add_flag("--no-files", o->no_files, "only summary.json and quality.txt (no mesh files)");
    cmd->callback([o]() { mesh_command(*o); });
  }
} // namespace rectify::app
