// `rectify map-thesis`: the thesis's R(x) curve as a map file (maps/).
#include <cstdio>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/version.h"
#include "common/plot.h"
#include "maps/map_set.h"
#include "maps/resistance_map.h"
#include "system/parameters.h"

namespace rectify::app
{
  namespace
  {
    struct MapThesisOptions
    {
      std::string case_path;
      std::string out_dir;
      std::size_t n = 25;
    };

    void map_thesis(const MapThesisOptions &o)
    {
      const CaseFile file = load_case(o.case_path);
      if (o.n < 2)
        throw InputError("--n " + std::to_string(o.n) + ": need at least 2 samples");
      const auto map = maps::thesis_resistance_map(o.n);
      const auto sys = system::SystemParameters::from_case(file);
      const std::filesystem::path out(o.out_dir);
      OutputLock lock;
      lock.acquire(out);
      // As a map set: the thesis's R(x) with the constant force area A_r.
      maps::map_set_from_resistance(map, sys.reed.pressure_area_m2).write(out);
      // Plot from 1 um up (log axes), without the closed-valve node at x = 0.
      CsvTable t({"opening_um", "R_Pa_s_per_m3"});
      for (std::size_t i = 1; i < map.openings().size(); ++i)
        {
          const double row[2] = {map.openings()[i] * 1e6, map.resistances()[i]};
          t.add_row(row);
        }
      t.write(out / "resistance-map-plot.csv");
      const bool plotted = render_plot(
        out / "resistance-map",
        {{"Thesis R(x): eq. 3.40 with floor 4.5e8 (closed valve: 1e17 at x = 0)",
          "tip opening [um]", "R [Pa s/m^3]", true, true,
          {{out / "resistance-map-plot.csv", "opening_um", "R_Pa_s_per_m3", "map nodes",
            "linespoints"}}}});
      write_json(out / "summary.json",
                 {{"command", "map-thesis"},
                  {"rectify_version", RECTIFY_VERSION},
                  {"build", build_info()},
                  {"n_nodes", map.openings().size()},
                  {"opening_m", map.openings()},
                  {"R_Pa_s_per_m3", map.resistances()},
                  {"metadata", map.metadata()},
                  {"A_eff_m2", sys.reed.pressure_area_m2},
                  {"files", {"manifest.json", "resistance.csv", "area.csv", plotted ? "resistance-map.png" : ""}}});
      std::printf("wrote the map set %s (R(x) at %zu nodes, A_eff = A_r = %s m^2)\n", out.c_str(),
                  map.openings().size(), format_number(sys.reed.pressure_area_m2).c_str());
    }
  } // namespace

  void register_map_commands(CLI::App &app)
  {
    auto  o   = std::make_shared<MapThesisOptions>();
    auto *cmd = app.add_subcommand(
      "map-thesis",
      "Write the thesis's valve as a map set: R(x) of eq. 3.40 (floor and closed value of sec. 3.2.4)\n"
      "and the constant force area A_r ([reed] pressure_area_m2).");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->add_option("--n", o->n, "samples from 2 to 1210 um, log-spaced")->capture_default_str();
    cmd->callback([o]() { map_thesis(*o); });
  }
} // namespace rectify::app
