// `rectify geometry`: reads a case's valve geometry ([geometry], [[port]]),
// checks it as every stage does, and draws it: the reed's outline with its
// fillets, the clamp line, the ports and the pocket's floor (geometry.png,
// .svg), with the outlines as CSV and the description, areas, seat lands and
// the smallest features in summary.json. For drawing a new valve before any
// meshing.
#include <cstdio>

#include "app/commands.h"
#include "common/io.h"
#include "common/output_lock.h"
#include "common/plot.h"
#include "common/valve_geometry.h"
#include "common/version.h"
#include "mesher/parameters.h"

namespace rectify::app
{
  namespace
  {
    struct GeometryOptions
    {
      std::string case_path;
      std::string out_dir;
    };

    /// A closed outline as CSV (the first point repeated at the end), x_m, y_m.
    std::string outline_csv(const geometry::Polygon &polygon)
    {
      CsvTable table({"x_m", "y_m"});
      for (const auto &p : polygon)
        table.add_row(std::vector<double>{p[0], p[1]});
      if (!polygon.empty())
        table.add_row(std::vector<double>{polygon.front()[0], polygon.front()[1]});
      return table.to_string();
    }

    PlotSeries series(const std::filesystem::path &file, const std::string &title)
    {
      PlotSeries s;
      s.data_file = file;
      s.x_column  = "x_m";
      s.y_column  = "y_m";
      s.title     = title;
      s.x_scale   = 1e3;
      s.y_scale   = 1e3;
      return s;
    }

    void run(const GeometryOptions &o)
    {
      const CaseFile file = load_case(o.case_path, false); // every stage reads it: unknown keys, ranges
      const auto     g    = ValveGeometry::from_case(file);
      const auto     mesh = mesher::MeshParameters::from_case(file);

      const std::filesystem::path out(o.out_dir);
      OutputLock                  lock;
      lock.acquire(out);

      const auto boundary = g.reed_boundary();
      const auto ports    = g.ports();
      const auto [y0, y1] = g.clamp_line_y();
      write_file_atomic(out / "reed.csv", outline_csv(boundary));
      write_file_atomic(out / "reed_corners.csv", outline_csv(g.reed_corners()));
      write_file_atomic(out / "clamp.csv", "x_m,y_m\n0," + format_number(y0) + "\n0," + format_number(y1) + "\n");
      const double hx = g.pocket_length_m, hy = 0.5 * g.pocket_width_m;
      write_file_atomic(out / "pocket.csv", outline_csv({{0, -hy}, {hx, -hy}, {hx, hy}, {0, hy}}));

      PlotPanel panel;
      panel.title      = "valve geometry: " + o.case_path;
      panel.x_label    = "x from the clamp line [mm]";
      panel.y_label    = "y [mm]";
      panel.equal_axes = true;
      panel.series.push_back(series(out / "pocket.csv", "pocket floor"));
      panel.series.push_back(series(out / "reed.csv", "reed"));
      auto clamp  = series(out / "clamp.csv", "clamp line");
      clamp.style = "lines lw 4";
      panel.series.push_back(clamp);

      nlohmann::json port_json = nlohmann::json::array();
      for (std::size_t k = 0; k < ports.size(); ++k)
        {
          const std::string name = "port-" + std::to_string(k + 1) + ".csv";
          write_file_atomic(out / name, outline_csv(ports[k].polygon()));
          panel.series.push_back(series(out / name, "port " + std::to_string(k + 1)));
          port_json.push_back(ports[k].to_json());
        }

      const auto     features = g.features();
      nlohmann::json feature_json = nlohmann::json::array();
      for (const auto &f : features)
        feature_json.push_back({{"size_m", f.size_m}, {"what", f.what}});

      const bool plotted = render_plot(out / "geometry", {panel});
      const nlohmann::json summary = {
        {"command", "geometry"},
        {"rectify_version", RECTIFY_VERSION},
        {"build", build_info()},
        {"case", o.case_path},
        {"valid", true},
        {"written_as", g.is_shorthand() ? "shorthand (rectangle over one circular port)" : "outline"},
        {"geometry", g.to_json()},
        {"reed_area_m2", g.reed_area_m2()},
        {"reed_perimeter_m", geometry::perimeter(boundary)},
        {"reed_centroid_m", {geometry::centroid(boundary)[0], geometry::centroid(boundary)[1]}},
        {"clamp_line_length_m", y1 - y0},
        {"ports", port_json},
        {"ports_area_m2", g.ports_area_m2()},
        {"seat_land_m", g.seat_land_m()},
        {"features_smallest_first", feature_json},
        {"mesh_size_reed_m", mesh.settings.size_reed_m},
        {"plot", plotted ? "geometry.png, geometry.svg" : "not drawn (gnuplot missing or failed; geometry.gp kept)"}};
      write_json(out / "summary.json", summary);
      std::printf("%s: valid geometry; reed %.4g mm^2 (%zu corners), %zu port(s) %.4g mm^2, narrowest seat land "
                  "%.4g mm, smallest feature %.4g mm (%s)\n%s\n",
                  o.case_path.c_str(), g.reed_area_m2() * 1e6, g.reed_corners().size(), ports.size(),
                  g.ports_area_m2() * 1e6, g.seat_land_m() * 1e3, features.front().size_m * 1e3,
                  features.front().what.c_str(),
                  plotted ? (out / "geometry.png").c_str() : "no plot: gnuplot missing or failed");
    }
  } // namespace

  void register_geometry_command(CLI::App &app)
  {
    auto  o   = std::make_shared<GeometryOptions>();
    auto *cmd = app.add_subcommand(
      "geometry", "Check a valve's geometry and draw it: the reed's outline, clamp line, ports and pocket.\n"
                  "Example: rectify geometry --case cases/geometries/two-ports.toml --out runs/two-ports-geometry");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->callback([o]() { run(*o); });
  }
} // namespace rectify::app
