#include "whatif/summary.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "common/io.h"
#include "common/plot.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  namespace
  {
    // ------------------------------------------------------------- the summary
    /// The designs' worst Goodman factor against key `k`, 1 marked: below
    /// it a reed does not survive its cycles.
    PlotPanel design_life_panel(const fs::path &data, const std::string &k, const std::string &label, double scale)
    {
      PlotPanel p{"Worst Goodman factor of the reeds (both sweeps): below 1 a reed does not survive", label,
                  "Goodman factor", false, true,
                  {{data, k, "worst_goodman_factor", "worst over the runs", "linespoints", scale, 1}}};
      p.levels.push_back({1.0, "survives above"});
      return p;
    }

    std::string axis_label(const std::string &key, double &scale)
    {
      scale = 1;
      if (key.size() > 2 && key.compare(key.size() - 2, 2, "_m") == 0)
        {
          scale = 1e3;
          return key + " [mm]";
        }
      return key;
    }



    const std::vector<std::string> numeric_columns = {
      "k_r_N_per_m", "f1_vacuum_Hz", "f1_oil_Hz", "m_r_eq321_kg", "R_10um_Pa_s_per_m3", "R_100um_Pa_s_per_m3",
      "A_eff_100um_m2", "map_openings", "bandwidth_Hz", "peak_velocity_m_per_s", "peak_velocity_frequency_Hz",
      "highest_velocity_m_per_s", "highest_velocity_frequency_Hz", "stored_pressure_low_Pa",
      "half_pressure_frequency_Hz", "velocity_valid_points", "pressure_valid_points", "worst_goodman_factor",
      "max_impact_velocity_m_per_s", "survives_to_Hz", "valid_to_Hz", "bandwidth_all_points_Hz",
      "peak_velocity_all_points_m_per_s"};

    /// whatif.csv, whatif.json and the plots, a design at a time.
    class Summary
    {
    public:
      Summary(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths)
        : bs(bs)
        , designs(designs)
        , paths(paths)
        , failures(read_failures(paths))
        , keys(design_keys(bs.designs))
        , plot_table(plot_columns())
      {
        for (const auto &k : keys)
          {
            std::set<std::string> distinct;
            for (const auto &dc : designs)
              distinct.insert(dc.design.values().value(k, nlohmann::json()).dump());
            if (distinct.size() > 1)
              varying.insert(k);
          }
        csv << "design";
        for (const auto &k : keys)
          csv << "," << k;
        csv << ",status";
        for (const auto &c : numeric_columns)
          csv << "," << c;
        csv << ",map_set,reason\n";
      }

      std::size_t write()
      {
        for (std::size_t i = 0; i < designs.size(); ++i)
          add_design(i);
        write_file_atomic(paths.out / "whatif.csv", csv.str());
        write_json_file();
        write_plots();
        return n_failed;
      }

    private:
      struct Curve
      {
        fs::path    file;          ///< the map set's map-curve.csv
        std::string design, title; ///< the design's name; its name and varied values
      };

      std::vector<std::string> plot_columns() const
      {
        std::vector<std::string> columns = {"index"};
        for (const auto &k : keys)
          columns.push_back(k);
        for (const auto &c : numeric_columns)
          columns.push_back(c);
        return columns;
      }
      void add_design(std::size_t i);
      void map_set_numbers(const DesignCase &dc, std::map<std::string, double> &v, nlohmann::json &row);
      void sweep_answers(const DesignCase &dc, std::map<std::string, double> &v, nlohmann::json &row,
                         bool answered[2]) const;
      void write_json_file() const;
      void write_plots() const;

      const BatchSettings           &bs;
      const std::vector<DesignCase> &designs;
      const Paths                   &paths;
      const std::vector<Failure>     failures;
      const std::vector<std::string> keys;
      std::set<std::string>          varying; ///< keys set to more than one value: the axes
      std::ostringstream             csv;
      nlohmann::json                 rows = nlohmann::json::array();
      CsvTable                       plot_table;
      std::vector<Curve>             curves;
      std::size_t                    n_failed = 0;
      const double                   nan      = std::nan("");
    };

    /// Design i's row: its failures, its map set's numbers, its sweeps'
    /// answers, in the table, the JSON and the plots' data.
    void Summary::add_design(std::size_t i)
    {
      const auto                   &dc = designs[i];
      const std::string             h  = dc.map_set_hash;
      std::map<std::string, double> v;
      for (const auto &c : numeric_columns)
        v[c] = nan;
      std::string status = "ok", reason;
      const auto  add_failure = [&](const std::string &stage, const std::string &why) {
        status = "failed";
        reason += (reason.empty() ? "" : "; ") + stage + ": " + why;
      };
      for (const auto &f : failures)
        if (std::find(f.designs.begin(), f.designs.end(), dc.design.name) != f.designs.end())
          add_failure(f.job, f.reason);
      nlohmann::json row = {{"design", dc.design.name}, {"values", dc.design.values()}, {"map_set_hash", h}};
      if (paths.map_set_done(h))
        map_set_numbers(dc, v, row);
      bool answered[2] = {false, false};
      sweep_answers(dc, v, row, answered);
      if (status == "ok" && (!paths.map_set_done(h) || !answered[0] || !answered[1]))
        add_failure("batch", "not finished");
      csv << dc.design.name;
      const auto values = dc.design.values();
      for (const auto &k : keys)
        {
          csv << ",";
          if (values.contains(k))
            csv << (values[k].is_number() ? exact(values[k].get<double>()) : values[k].get<std::string>());
        }
      csv << "," << status;
      std::vector<double> plot_row = {static_cast<double>(i + 1)};
      for (const auto &k : keys)
        plot_row.push_back(values.contains(k) && values[k].is_number() ? values[k].get<double>() : nan);
      for (const auto &c : numeric_columns)
        {
          csv << "," << (std::isfinite(v[c]) ? exact(v[c]) : "");
          row[c] = std::isfinite(v[c]) ? nlohmann::json(v[c]) : nlohmann::json(nullptr);
          plot_row.push_back(v[c]);
        }
      std::string quoted = reason;
      std::replace(quoted.begin(), quoted.end(), '"', '\'');
      std::replace(quoted.begin(), quoted.end(), '\n', ' ');
      csv << "," << h << ",\"" << quoted << "\"\n";
      row["status"] = status;
      row["reason"] = reason;
      n_failed += status != "ok";
      rows.push_back(row);
      plot_table.add_row(plot_row);
    }

    /// The map set's reed and its R and A_eff at 10 and 100 um; the design's
    /// link to it; its curve for the family plot.
    void Summary::map_set_numbers(const DesignCase &dc, std::map<std::string, double> &v, nlohmann::json &row)
    {
      const std::string h = dc.map_set_hash;
      const auto set = maps::MapSet::read(paths.cached(h));
      const auto link = paths.design(dc.design.name) / "map-set";
      std::error_code ec;
      if (fs::read_symlink(link, ec) != paths.cached(h))
        {
          fs::remove(link, ec);
          fs::create_directory_symlink(paths.cached(h), link);
        }
      if (set.reed())
        {
          v["k_r_N_per_m"]  = set.reed()->stiffness_N_per_m;
          v["f1_vacuum_Hz"] = set.reed()->frequency_Hz;
          v["f1_oil_Hz"]    = set.reed()->frequency_in_fluid_Hz;
          v["m_r_eq321_kg"] = set.reed()->effective_mass_eq321_kg;
        }
      const auto in_range = [&](double x) {
        return x >= dc.openings.from_m && x <= dc.openings.to_m;
      };
      if (in_range(10e-6))
        v["R_10um_Pa_s_per_m3"] = set.resistance().evaluate(10e-6).resistance;
      if (in_range(100e-6))
        {
          v["R_100um_Pa_s_per_m3"] = set.resistance().evaluate(100e-6).resistance;
          v["A_eff_100um_m2"]      = set.area().evaluate(100e-6).area;
        }
      v["map_openings"] = static_cast<double>(set.manifest().at("points").size());
      std::string title = dc.design.name;
      for (std::size_t e = 0; e < dc.design.entries.size(); ++e)
        if (varying.contains(dc.design.entries[e].table + "." + dc.design.entries[e].key))
          title += " " + dc.design.entries[e].key + "=" + dc.design.text_values[e];
      curves.push_back({paths.cached(h) / "map-curve.csv", dc.design.name, title});
      row["map_set"] = paths.cached(h).string();
    }

    /// The answers the sweep jobs wrote (answer.json marks each finished);
    /// the design's worst Goodman factor and fastest impact over both.
    void Summary::sweep_answers(const DesignCase &dc, std::map<std::string, double> &v, nlohmann::json &row,
                                bool answered[2]) const
    {
      for (const std::string kind : {"velocity", "pressure"})
        {
          // The answers the sweep job wrote (answer.json marks it finished).
          const auto dir = paths.design(dc.design.name) / kind;
          if (!fs::exists(dir / "answer.json"))
            continue;
          const auto a   = read_json_file(dir / "answer.json");
          const auto get = [&](const char *key) {
            return a.contains(key) && a[key].is_number() ? a[key].get<double>() : nan;
          };
          const char *const taken[][2] =
            {{"peak_velocity_m_per_s", "peak_velocity_m_per_s"},
             {"peak_velocity_frequency_Hz", "peak_velocity_frequency_Hz"},
             {"highest_velocity_m_per_s", "highest_velocity_m_per_s"},
             {"highest_velocity_frequency_Hz", "highest_velocity_frequency_Hz"},
             {"bandwidth_Hz", "first_reversal_Hz"},
             {"bandwidth_all_points_Hz", "all_points_first_reversal_Hz"},
             {"peak_velocity_all_points_m_per_s", "all_points_peak_velocity_m_per_s"},
             {"survives_to_Hz", "survives_to_Hz"},
             {"valid_to_Hz", "valid_to_Hz"}};
          if (kind == "velocity")
            for (const auto &[column, key] : taken)
              v[column] = get(key);
          else
            {
              v["stored_pressure_low_Pa"]     = get("low_frequency_pressure_Pa");
              v["half_pressure_frequency_Hz"] = get("half_pressure_frequency_Hz");
            }
          // the design's worst over both sweeps
          const double g = get("worst_goodman_factor"), impact = get("max_impact_velocity_m_per_s");
          if (std::isfinite(g))
            v["worst_goodman_factor"] = std::isfinite(v["worst_goodman_factor"]) ? std::min(v["worst_goodman_factor"], g) : g;
          if (std::isfinite(impact))
            v["max_impact_velocity_m_per_s"] = std::isfinite(v["max_impact_velocity_m_per_s"]) ?
                                                 std::max(v["max_impact_velocity_m_per_s"], impact) : impact;
          v[kind + "_valid_points"]    = get("valid_points");
          answered[kind == "velocity" ? 0 : 1] = true;
          row[kind + "_points"]        = a.value("points", 0);
          row[kind + "_failed_points"] = a.value("failed_points", 0);
        }
    }

    void Summary::write_json_file() const
    {
  write_json(paths.out / "whatif.json",
             {{"command", "whatif"},
              {"rectify_version", RECTIFY_VERSION},
              {"batch", bs.definition()},
              {"columns",
               {{"bandwidth_Hz", "the loaded sweep's first velocity reversal (linear between the points around it), "
                                 "from its valid runs only (system/validity.h: no reed beyond its map or stop, no "
                                 "pressure below cavitation, every reed's Goodman factor at least 1)"},
                {"peak_velocity_m_per_s",
                 "the loaded sweep's largest mean output velocity below its first reversal (the usable band), at "
                 "peak_velocity_frequency_Hz; valid runs only"},
                {"*_all_points_*", "the same from every run, valid or not: what the states hardware cannot reach would claim"},
                {"worst_goodman_factor", "the smallest Goodman factor of either reed over every run of both sweeps"},
                {"max_impact_velocity_m_per_s", "the fastest seat or stop impact of either reed over both sweeps"},
                {"survives_to_Hz", "the loaded sweep's highest frequency up to which every run's Goodman factor is >= 1"},
                {"valid_to_Hz", "the loaded sweep's highest frequency up to which every run is valid"},
                {"highest_velocity_m_per_s", "the largest anywhere in the sweep (a band above a reversal can be higher)"},
                {"half_pressure_frequency_Hz",
                 "the no-flow sweep's first frequency where the stored pressure has fallen to half of its value at "
                 "the lowest frequency (linear in log f)"},
                {"k_r_N_per_m, f1_*, m_r_eq321_kg", "the reed from the map set's stiffness solve"},
                {"R_*um, A_eff_100um_m2", "the map set's R(x) and A_eff(x) at 10 and 100 um tip opening"}}},
              {"designs", rows}});

    }

    /// Plots (in plots/, beside their data): the answers against each
    /// varied key, the family of R(x).
    void Summary::write_plots() const
    {
  const fs::path plots = paths.out / "plots";
  ensure_directory(plots);
  plot_table.write(plots / "designs.csv");
  const fs::path data = plots / "designs.csv";
  for (const auto &k : keys)
    {
      if (!varying.contains(k))
        continue;
      double            scale = 1;
      const std::string label = axis_label(k, scale);
      std::string       file  = k;
      std::replace(file.begin(), file.end(), '.', '-');
      render_plot(plots / ("whatif-" + file),
                  {{"Bandwidth: first velocity reversal (loaded) and half stored pressure (no flow)", label,
                    "frequency [Hz]", false, false,
                    {{data, k, "bandwidth_Hz", "first velocity reversal, loaded", "linespoints", scale, 1},
                     {data, k, "half_pressure_frequency_Hz", "stored pressure at half, no flow", "linespoints",
                      scale, 1},
                     {data, k, "peak_velocity_frequency_Hz", "peak velocity's frequency", "linespoints", scale, 1},
                     {data, k, "survives_to_Hz", "the reed survives (Goodman >= 1) up to", "linespoints", scale, 1},
                     {data, k, "bandwidth_all_points_Hz", "first reversal, every run (not valid ones too)",
                      "points pt 6", scale, 1}}},
                   {"Peak mean output velocity (loaded)", label, "velocity [mm/s]", false, false,
                    {{data, k, "peak_velocity_m_per_s", "below the first reversal", "linespoints", scale, 1e3},
                     {data, k, "highest_velocity_m_per_s", "anywhere in the sweep", "linespoints", scale, 1e3}}},
                   design_life_panel(data, k, label, scale),
                   {"Fastest impact at seat or stop (both sweeps)", label, "impact velocity [m/s]", false, false,
                    {{data, k, "max_impact_velocity_m_per_s", "either reed", "linespoints", scale, 1}}},
                   {"Reed stiffness k_r (FE)", label, "k_r [N/m]", true, true,
                    {{data, k, "k_r_N_per_m", "k_r", "linespoints", scale, 1}}},
                   {"Reed's first mode (FE)", label, "f1 [Hz]", true, true,
                    {{data, k, "f1_vacuum_Hz", "in vacuum", "linespoints", scale, 1},
                     {data, k, "f1_oil_Hz", "in oil (eq. 3.20's added mass)", "linespoints", scale, 1}}}});
    }
  if (!curves.empty())
    {
      std::vector<PlotSeries> r, a;
      for (const auto &[file, design, title] : curves)
        {
          const fs::path copy = plots / ("map-curve-" + design + ".csv");
          write_file_atomic(copy, read_text(file));
          r.push_back({copy, "opening_m", "R_Pa_s_per_m3", title, "lines", 1e6, 1});
          a.push_back({copy, "opening_m", "A_eff_m2", title, "lines", 1e6, 1e6});
        }
      render_plot(plots / "resistance-family",
                  {{"R(x) of every design (map sets)", "tip opening [um]", "R [Pa s/m^3]", true, true, r},
                   {"A_eff(x) of every design", "tip opening [um]", "A_eff [mm^2]", true, false, a}});
    }
    }
  } // namespace

  std::size_t write_summary(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths)
  {
    return Summary(bs, designs, paths).write();
  }
} // namespace rectify::whatif
