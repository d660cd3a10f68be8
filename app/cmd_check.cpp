// `rectify check`: reads a case file as every stage does, reports every
// parameter (given or default) and the derived model constants, and exits
// non-zero on the first problem. For editing a case before a long run.
#include <algorithm>
#include <cstdio>

#include "app/commands.h"
#include "common/case_keys.h"
#include "common/output_lock.h"
#include "common/io.h"
#include "common/version.h"
#include "mesher/parameters.h"
#include "stiffness_solver/parameters.h"
#include "stokes_solver/parameters.h"
#include "system/model.h"

namespace rectify::app
{
  namespace
  {
    struct CheckOptions
    {
      std::string case_path;
      std::string out_dir;
      bool        case_given = false;
    };

    void check(const CheckOptions &o)
    {
      const CaseFile file = load_case(o.case_path); // every stage, unknown keys
      const auto     sys  = system::SystemParameters::from_case(file);
      const auto     st   = stiffness::StiffnessParameters::from_case(file);
      const auto     mesh = mesher::MeshParameters::from_case(file);
      const auto     flow = stokes::FlowParameters::from_case(file);
      const auto     valves = system::load_valve_maps(sys);
      nlohmann::json valve_maps = nlohmann::json::array();
      for (const auto &v : valves)
        valve_maps.push_back({{"map_set", v.name()},
                              {"n_nodes", v.resistance().openings().size()},
                              {"interpolation", maps::to_string(v.resistance().interpolation())},
                              {"closed_R_Pa_s_per_m3", v.resistance().closed_resistance()},
                              {"max_opening_m", v.resistance().max_opening()},
                              {"seated_area_m2", v.seated_area_m2()},
                              {"A_eff_range_m2", {*std::min_element(v.area().areas().begin(), v.area().areas().end()),
                                                  *std::max_element(v.area().areas().begin(), v.area().areas().end())}},
                              {"reed", v.reed() ? v.reed()->to_json() : nlohmann::json(nullptr)}});
      nlohmann::json summary = {
        {"command", "check"},
        {"rectify_version", RECTIFY_VERSION},
        {"build", build_info()},
        {"case", o.case_path},
        {"valid", true},
        {"system", sys.to_json()},
        {"model_constants_loaded", system::ModelConstants(sys, system::Scenario::loaded).to_json()},
        {"valve_maps", {{"outlet", valve_maps[0]}, {"inlet", valve_maps[1]}}},
        {"geometry", st.geometry.to_json()},
        {"flow", flow.settings.to_json()},
        {"mesh", mesh.settings.to_json()},
        {"stiffness", st.settings.to_json()},
        {"reed_material",
         {{"youngs_modulus_Pa", st.material.youngs_modulus_Pa},
          {"poisson_ratio", st.material.poisson_ratio},
          {"density_kg_per_m3", st.material.density_kg_per_m3}}}};
      const std::filesystem::path out(o.out_dir);
      if (!o.case_given)
        {
          // No --case: say where the default case was looked for.
          nlohmann::json places = nlohmann::json::array();
          std::fprintf(stderr, "no --case: the reference case, looked for in this order:\n");
          for (const auto &p : reference_case_search_path())
            {
              const bool found = std::filesystem::is_regular_file(p);
              places.push_back({{"path", p.string()}, {"exists", found}});
              std::fprintf(stderr, "  %s%s\n", p.c_str(), found ? "  (exists)" : "");
            }
          summary["default_case_search"] = places;
        }
      const std::string keys = case_keys_csv(file); // every key a stage read, with its range
      summary["n_keys"]      = file.read_keys().size();
      OutputLock lock;
      lock.acquire(out);
      write_file_atomic(out / "keys.csv", keys);
      write_json(out / "summary.json", summary);
      std::printf("%s: valid; every parameter, given or default, in %s; each key's range in %s\n",
                  o.case_path.c_str(), (out / "summary.json").c_str(), (out / "keys.csv").c_str());
    }
  } // namespace

  void register_check_command(CLI::App &app)
  {
    auto  o   = std::make_shared<CheckOptions>();
    auto *cmd = app.add_subcommand(
      "check", "Check a case file as every stage reads it, and list all its parameters.\n"
               "Example: rectify check --case my.toml --out runs/check");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->callback([o, cmd]() {
      o->case_given = cmd->count("--case") > 0;
      check(*o);
    });
  }
} // namespace rectify::app
