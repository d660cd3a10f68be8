// `rectify design` (design/): the map set of a coarse valve. Its interpolant
// is checked against extra Stokes solves at random openings on the same FE
// reed shape; two processes give the one-process map; an interrupted run
// resumes; bad [design] input is refused before any work.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/map_set.h"
#include "mesher/mesher.h"
#include "mesher/parameters.h"
#include "stokes_solver/resistance_sweep.h"
#include "tests/cli_helpers.h"

using namespace rectify;
using namespace rectify::test_support;

namespace
{
  // The coarse valve, 2 % interpolation tolerance.
  const std::string coarse_case = coarse_valve_case("0.02");

  nlohmann::json read_json(const std::filesystem::path &path)
  {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
  }
} // namespace

TEST(Design, MapSetInterpolatesExtraSolvesTwoProcessesAgreeAndItResumes)
{
  const auto dir = scratch("design");
  write_file_atomic(dir / "coarse.toml", coarse_case);
  const std::string args = "design --case " + (dir / "coarse.toml").string() + " --out ";
  const auto        one  = rectify_cli(args + (dir / "one").string());
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const auto set = maps::MapSet::read(dir / "one");
  const auto manifest = read_json(dir / "one" / "manifest.json");

  // Provenance: the case tables, code version, per point its numbers.
  for (const char *table : {"geometry", "fluid", "reed_material", "mesh", "flow", "stiffness"})
    {
      ASSERT_TRUE(manifest["depends_on"].contains(table)) << table;
      EXPECT_EQ(manifest["depends_on"][table]["hash"].get<std::string>().size(), 16u);
    }
  EXPECT_EQ(manifest["rectify_version"], RECTIFY_VERSION);
  EXPECT_FALSE(manifest["code_revision"].get<std::string>().empty());
  const auto &points = manifest["points"];
  ASSERT_GE(points.size(), 4u);
  for (const auto &p : points)
    {
      EXPECT_GT(p["n_dofs"].get<double>(), 1000);
      EXPECT_GE(p["iterations"].get<double>(), 1);
      EXPECT_LT(p["mass_balance_rel_error"].get<double>(), 1e-8);
      EXPECT_GT(p["wall_time_s"].get<double>(), 0);
    }
  EXPECT_TRUE(manifest["interpolation_error"]["converged"].get<bool>());
  EXPECT_LE(manifest["interpolation_error"]["R_max_rel"].get<double>(), 0.02); // the case's tolerance
  EXPECT_LE(manifest["interpolation_error"]["A_eff_max_rel"].get<double>(), 0.02);
  ASSERT_TRUE(set.reed());
  EXPECT_NEAR(set.reed()->stiffness_N_per_m, 6500, 300); // coarse reed, docs/stiffness.md: 6636 at 6x5x1
  EXPECT_NEAR(set.seated_area_m2(), M_PI * 0.25 * 3.175e-3 * 3.175e-3, 1e-12);
  // Thin-gap physics in the map: R ~ x^-3 at small openings, A_eff above the port's area.
  const double n = std::log(set.resistance().evaluate(10e-6).resistance / set.resistance().evaluate(40e-6).resistance) /
                   std::log(4.0);
  EXPECT_NEAR(n, 3.0, 0.1);
  EXPECT_GT(set.area().evaluate(10e-6).area, 1.5 * set.seated_area_m2());
  // The reed's fluid loading at every opening (docs/fluid-loading.md):
  // reciprocal, the squeeze film ~ x^-3 and the added mass ~ 1/x in the thin
  // gap, the damping at a fixed drop below the port-shut one, the modal
  // area below A_eff (the shape is below 1 over the port).
  ASSERT_TRUE(set.loading());
  const auto &rows = set.loading()->rows();
  ASSERT_EQ(rows.size(), points.size());
  for (std::size_t i = 0; i < rows.size(); ++i)
    {
      EXPECT_LT(rows[i].asymmetry, 1e-6) << i;
      EXPECT_LT(rows[i].damping_fixed_dp_N_s_per_m, rows[i].damping_N_s_per_m) << i;
      EXPECT_GT(rows[i].A_modal_m2, 0.2 * set.area().evaluate(rows[i].opening_m).area) << i;
      EXPECT_LT(rows[i].A_modal_m2, set.area().evaluate(rows[i].opening_m).area) << i;
      if (i > 0)
        {
          EXPECT_LT(rows[i].damping_fixed_dp_N_s_per_m, rows[i - 1].damping_fixed_dp_N_s_per_m) << i;
          EXPECT_LT(rows[i].added_mass_kg, rows[i - 1].added_mass_kg) << i; // it rises toward the seat
        }
    }
  // The seat film's modal area (the suction limit's): the FE shape integrated
  // over the reed's footprint less the port (the reference geometry: 6.1 x
  // 5.08 mm less a 3.175 mm port), the shape's mean there about 0.4 (the
  // beam shape's: 0.41, tests/test_mesher.cpp).
  ASSERT_TRUE(set.loading()->film_modal_area_m2());
  const double land = 6.1e-3 * 5.08e-3 - M_PI * 0.25 * 3.175e-3 * 3.175e-3;
  EXPECT_GT(*set.loading()->film_modal_area_m2(), 0.3 * land);
  EXPECT_LT(*set.loading()->film_modal_area_m2(), 0.5 * land);
  const auto l10 = set.loading()->evaluate(10e-6), l40 = set.loading()->evaluate(40e-6);
  EXPECT_NEAR(std::log(l10.damping / l40.damping) / std::log(4.0), 3.0, 0.15);
  EXPECT_NEAR(std::log(l10.added_mass / l40.added_mass) / std::log(4.0), 1.0, 0.15);

  // The interpolant against extra solves at random openings, on the same FE shape.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(std::log(10e-6), std::log(300e-6));
  write_file_atomic(dir / "fe-shape.toml", replace(coarse_case, "[mesh]\n", "[mesh]\nshape = \"table\"\nshape_table = \"" +
                                                                          (dir / "one" / "reed" / "shape.csv").string() + "\"\n"));
  for (int k = 0; k < 3; ++k)
    {
      const double x  = std::exp(u(rng));
      const auto   st = rectify_cli("stokes --no-vtu --case " + (dir / "fe-shape.toml").string() + " --opening " +
                                    format_number(x) + " --out " + (dir / ("extra" + std::to_string(k))).string());
      ASSERT_EQ(st.exit_code, 0) << st.output;
      const auto s = read_json(dir / ("extra" + std::to_string(k)) / "summary.json");
      EXPECT_NEAR(set.resistance().evaluate(x).resistance / s["R_Pa_s_per_m3"].get<double>(), 1.0, 0.02) << x;
      EXPECT_NEAR(set.area().evaluate(x).area / s["A_eff_m2"].get<double>(), 1.0, 0.02) << x;
      EXPECT_NEAR(set.loading()->evaluate(x).damping / s["reed_loading"]["damping_fixed_dp_N_s_per_m"].get<double>(),
                  1.0, 0.03) << x;
      EXPECT_NEAR(set.loading()->evaluate(x).added_mass / s["reed_loading"]["added_mass_kg"].get<double>(), 1.0, 0.03)
        << x;
    }

  // Two processes: the same map to 1e-9.
  const auto two = std::system((mpirun(2) + RECTIFY_BINARY + " " + args + (dir / "two").string() + " > " +
                                (dir / "two.log").string() + " 2>&1")
                                 .c_str());
  ASSERT_EQ(two, 0) << std::ifstream(dir / "two.log").rdbuf();
  const auto set2 = maps::MapSet::read(dir / "two");
  ASSERT_EQ(set2.resistance().openings(), set.resistance().openings());
  for (std::size_t i = 0; i < set.resistance().openings().size(); ++i)
    EXPECT_NEAR(set2.resistance().resistances()[i] / set.resistance().resistances()[i], 1.0, 1e-9) << i;
  for (std::size_t i = 0; i < set.area().openings().size(); ++i)
    EXPECT_NEAR(set2.area().areas()[i] / set.area().areas()[i], 1.0, 1e-9) << i;
  for (std::size_t i = 0; i < set.loading()->rows().size(); ++i)
    {
      EXPECT_NEAR(set2.loading()->rows()[i].damping_N_s_per_m / set.loading()->rows()[i].damping_N_s_per_m, 1.0, 1e-9)
        << i;
      EXPECT_NEAR(set2.loading()->rows()[i].added_mass_kg / set.loading()->rows()[i].added_mass_kg, 1.0, 1e-9) << i;
    }
  EXPECT_EQ(read_json(dir / "two" / "manifest.json")["settings"]["n_processes"], 2);

  // Interrupted after some openings: the run again solves only the rest.
  const auto partial = dir / "one" / "partial" / "openings-partial.csv";
  std::ifstream in(partial);
  std::string   text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (int cut = 0; cut < 2; ++cut)
    text.erase(text.find_last_of('\n', text.size() - 2) + 1);
  write_file_atomic(partial, text);
  std::filesystem::remove(dir / "one" / "manifest.json");
  const auto again = rectify_cli(args + (dir / "one").string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  std::size_t solved = 0;
  for (std::size_t pos = 0; (pos = again.output.find("DoFs,", pos)) != std::string::npos; ++pos)
    ++solved;
  EXPECT_EQ(solved, 2u) << again.output;
  EXPECT_NE(again.output.find("(" + std::to_string(points.size() - 2) + " from the checkpoint)"), std::string::npos)
    << again.output;
  const auto set3 = maps::MapSet::read(dir / "one");
  EXPECT_EQ(set3.resistance().resistances(), set.resistance().resistances());
  std::filesystem::remove_all(dir);
}

// Without openings_to_m the openings run to the reed's stop, or as far as
// the mesher reaches, and say by how much they fall short.
TEST(Design, TheOpeningsRunToTheStopOrSayWhyAndByHowMuchTheyEndShort)
{
  const auto reference = stokes::SweepSettings::from_case(CaseFile::load(reference_case_path()));
  EXPECT_TRUE(reference.to_stop);
  EXPECT_NEAR(reference.stop_lift_m, 2.0e-3 - 0.127e-3, 1e-12);
  EXPECT_NEAR(reference.to_m, 2.0e-3 - 0.127e-3 - 2 * 10e-6, 1e-12); // the mesher's reach
  const auto why = reference.short_of_stop();
  EXPECT_NE(why.find("20 um short of the reed's stop"), std::string::npos) << why;
  EXPECT_NE(why.find("min_slab_margin_m"), std::string::npos) << why;

  const auto guarded = stokes::SweepSettings::from_case(
    CaseFile::parse("[geometry]\nstop_height_m = 1.5e-3\n", "guard.toml"));
  EXPECT_NEAR(guarded.to_m, 1.5e-3 - 0.127e-3, 1e-12);
  EXPECT_EQ(guarded.short_of_stop(), "");

  // A thin reed near its stop: the gap treated as closed (gap_cutoff_ratio
  // x the opening, 5 % of 1.9 mm) would be thicker than the reed (0.9 x 80
  // um); the closed part shrinks towards the clamp instead, and the mesh
  // reaches the stop (a what-if's 0.08 mm design failed there).
  const auto thin = CaseFile::parse("[geometry]\nreed_thickness_m = 0.08e-3\n", "thin.toml");
  const auto mesh = mesher::MeshParameters::from_case(thin);
  const auto thin_sweep = stokes::SweepSettings::from_case(thin);
  EXPECT_GT(mesh.cutoff_reach_m(), mesh.ceiling_reach_m());
  EXPECT_EQ(thin_sweep.to_m, mesh.ceiling_reach_m());
  const auto near_stop = mesher::mesh_valve(mesh, thin_sweep.to_m);
  EXPECT_LT(near_stop.info.cutoff_thickness_m, 0.9 * 0.08e-3);
  EXPECT_LT(near_stop.info.cutoff_thickness_m, 0.05 * thin_sweep.to_m);
  EXPECT_GT(near_stop.info.cutoff_thickness_m, 0.0);
  // at a small opening the ratio's station as before
  const auto small = mesher::mesh_valve(mesh, 100e-6);
  EXPECT_GE(small.info.cutoff_thickness_m, 0.05 * 100e-6 * (1 - 1e-12));
}

TEST(Design, BadDesignSettingsAreRefusedBeforeAnyWork)
{
  const auto dir = scratch("design_bad");
  for (const auto &[text, needle] : std::vector<std::pair<std::string, std::string>>{
         {"[design]\ntolerance = 0\n", "tolerance"},
         {"[design]\nopenings_from_m = -1e-6\n", "openings_from_m"},
         {"[design]\nopenings_from_m = 1e-4\nopenings_to_m = 1e-5\n", "openings_to_m"},
         {"[design]\nopenings_to_m = 1.95e-3\n", "ceiling"},
         {"[design]\nopenings_to_m = 1.86e-3\n", "beyond the mesher's reach"},
         {"[geometry]\nstop_height_m = 1.5e-3\n[design]\nopenings_to_m = 1.4e-3\n", "beyond the reed's stop"},
         {"[design]\ninitial_openings = 2\n", "initial_openings"},
         {"[design]\ntolerence = 0.01\n", "tolerence"}})
    {
      write_file_atomic(dir / "bad.toml", text);
      const auto r = rectify_cli("design --case " + (dir / "bad.toml").string() + " --out " + (dir / "out").string());
      EXPECT_EQ(r.exit_code, 2) << text << r.output;
      EXPECT_NE(r.output.find(needle), std::string::npos) << r.output;
      EXPECT_FALSE(std::filesystem::exists(dir / "out" / "manifest.json"));
    }
  std::filesystem::remove_all(dir);
}
