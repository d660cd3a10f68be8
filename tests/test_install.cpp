// The installed tool (`cmake --install`): it runs from any folder, finds its
// reference case under the install prefix (not in the source tree), and says
// which version, revision and libraries it was built with.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <sys/wait.h>

#include "common/io.h"
#include "tests/cli_helpers.h"

using namespace rectify;
using namespace rectify::test_support;

namespace
{
  int run(const std::string &command, const std::filesystem::path &log)
  {
    return std::system((command + " > " + log.string() + " 2>&1").c_str());
  }

  /// What the clock measured: a summary's key or a table's column naming a
  /// wall or CPU time
  bool is_clock_key(const std::string &key)
  {
    return key.find("wall_time") != std::string::npos || key.find("cpu_time") != std::string::npos;
  }

  nlohmann::json timeless(nlohmann::json j)
  {
    erase_keys(j, is_clock_key);
    return j;
  }
} // namespace

TEST(Install, TheInstalledToolRunsFromAnyFolderOnItsOwnReferenceCase)
{
  const auto dir    = scratch("install");
  const auto prefix = dir / "prefix";
  ASSERT_EQ(run("cmake --install " + std::string(RECTIFY_BUILD_DIR) + " --prefix " + prefix.string(), dir / "install.log"),
            0)
    << read_text(dir / "install.log");
  const auto tool = prefix / "bin" / "rectify";
  ASSERT_TRUE(std::filesystem::exists(tool));
  EXPECT_TRUE(std::filesystem::exists(prefix / "share" / "rectify" / "cases" / "reference.toml"));
  EXPECT_TRUE(std::filesystem::exists(prefix / "share" / "rectify" / "cases" / "thesis-resistance.csv"));
  EXPECT_TRUE(std::filesystem::exists(prefix / "share" / "doc" / "rectify" / "map-sets.md"));

  // From another folder, without --case: the installed reference case.
  const auto elsewhere = dir / "elsewhere";
  std::filesystem::create_directories(elsewhere);
  const std::string in_elsewhere = "cd " + elsewhere.string() + " && env -u RECTIFY_DATA_DIR " + tool.string();
  ASSERT_EQ(run(in_elsewhere + " check --out check", dir / "check.log"), 0) << read_text(dir / "check.log");
  std::ifstream check_in(elsewhere / "check" / "summary.json");
  const auto    check = nlohmann::json::parse(check_in);
  const auto    used  = check["case"].get<std::string>();
  EXPECT_EQ(used.rfind(prefix.string(), 0), 0u) << "the installed tool used " << used;
  ASSERT_GE(check["default_case_search"].size(), 2u);
  EXPECT_EQ(check["default_case_search"][0]["path"].get<std::string>().rfind(prefix.string(), 0), 0u);
  EXPECT_TRUE(check["default_case_search"][0]["exists"].get<bool>());
  EXPECT_NE(read_text(dir / "check.log").find("looked for in this order"), std::string::npos);

  // A short simulation from there, on the installed case and its R(x) map.
  ASSERT_EQ(run(in_elsewhere + " simulate --scenario no-flow --frequency 50 --cycles 1 --out sim", dir / "sim.log"), 0)
    << read_text(dir / "sim.log");
  std::ifstream sim_in(elsewhere / "sim" / "summary.json");
  const auto    sim = nlohmann::json::parse(sim_in);
  EXPECT_GT(sim["stored_pressure_Pa"].get<double>(), 0);
  for (const char *library : {"rectify", "revision", "deal.II", "PETSc", "SUNDIALS", "TetGen", "CGAL"})
    EXPECT_FALSE(sim["build"][library].get<std::string>().empty()) << library;

  // --version: the version, the revision and the libraries.
  ASSERT_EQ(run(tool.string() + " --version", dir / "version.log"), 0);
  const auto version = read_text(dir / "version.log");
  for (const char *word : {"rectify " RECTIFY_VERSION, "revision", "deal.II", "PETSc", "SUNDIALS", "TetGen", "CGAL"})
    EXPECT_NE(version.find(word), std::string::npos) << version;
  // the CVODE built here goes along and is the one loaded (scripts/cvode.sh)
  if (!std::string(RECTIFY_BUILT_CVODE).empty())
    {
      EXPECT_NE(version.find("CVODE loaded from " + std::filesystem::canonical(prefix).string() + "/"),
                std::string::npos)
        << version;
    }

  // The finite-element commands, through the front end, from rectify-fe.
  EXPECT_TRUE(std::filesystem::exists(prefix / "bin" / "rectify-fe"));
  ASSERT_EQ(run(in_elsewhere + " map-stiffness --help", dir / "fe.log"), 0) << read_text(dir / "fe.log");
  EXPECT_NE(read_text(dir / "fe.log").find("--thickness"), std::string::npos) << read_text(dir / "fe.log");
  std::filesystem::remove_all(dir);
}

// The system commands' executable loads no finite-element library (its
// start-up is a few milliseconds; docs/benchmarks.md), the FE one does.
TEST(Install, TheFrontEndLoadsNoFiniteElementLibrary)
{
  const auto dir = scratch("front-end");
  const std::filesystem::path front_end(RECTIFY_BINARY);
  const auto fe = front_end.parent_path() / "rectify-fe";
  ASSERT_EQ(run("ldd " + front_end.string(), dir / "front.log"), 0);
  ASSERT_EQ(run("ldd " + fe.string(), dir / "fe.log"), 0);
  const auto front = read_text(dir / "front.log"), back = read_text(dir / "fe.log");
  for (const char *library : {"libdeal.ii", "libpetsc", "libmpi", "libtet", "libslepc", "libopenblas"})
    EXPECT_EQ(front.find(library), std::string::npos) << library << " in\n" << front;
  for (const char *library : {"libdeal.ii", "libtet"})
    EXPECT_NE(back.find(library), std::string::npos) << library << " not in\n" << back;
  EXPECT_NE(front.find("libsundials_cvode"), std::string::npos) << front;

  // An FE command given to the front end runs in rectify-fe with the same
  // arguments and exit code; the help names `rectify`.
  EXPECT_EQ(run(front_end.string() + " stokes --help", dir / "help.log"), 0);
  const auto help = read_text(dir / "help.log");
  EXPECT_NE(help.find("--flow-rate"), std::string::npos) << help;
  EXPECT_EQ(help.find("rectify-fe stokes"), std::string::npos) << help;
  const int status = run(front_end.string() + " stiffness --case " + (dir / "missing.toml").string() +
                          " --out " + (dir / "x").string(), dir / "bad.log");
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2) << read_text(dir / "bad.log");
  EXPECT_NE(read_text(dir / "bad.log").find("missing.toml"), std::string::npos) << read_text(dir / "bad.log");
  EXPECT_FALSE(std::filesystem::exists(dir / "x"));
  std::filesystem::remove_all(dir);
}

// The CVODE that scripts/cvode.sh builds from Debian's source at -O2 against
// Debian's own library, in the same binary (the loader takes Debian's when
// LD_LIBRARY_PATH names its folder: the tool's RUNPATH gives way to it):
// every number of a run the same to the last bit, through valve events,
// reinitialisations and Jacobians, with and without the effects' difference
// quotients; only the wall times differ.
TEST(Install, TheCvodeBuiltHereRunsAsDebiansBitForBit)
{
  const std::string built = RECTIFY_BUILT_CVODE;
  if (built.empty())
    GTEST_SKIP() << "built with Debian's CVODE (scripts/cvode.sh found no source): nothing to compare";
  const auto dir    = scratch("cvode");
  const auto debian = std::filesystem::path(RECTIFY_DEBIAN_CVODE);
  const std::string as_debian = "env LD_LIBRARY_PATH=" + debian.parent_path().string() + " ";
  const std::string tool      = RECTIFY_BINARY;

  // Which library each way loads.
  ASSERT_EQ(run(tool + " --version", dir / "built.log"), 0);
  ASSERT_EQ(run(as_debian + tool + " --version", dir / "debian.log"), 0);
  EXPECT_NE(read_text(dir / "built.log").find("CVODE loaded from " + std::filesystem::canonical(built).string()),
            std::string::npos) << read_text(dir / "built.log");
  EXPECT_NE(read_text(dir / "debian.log").find("CVODE loaded from " + std::filesystem::canonical(debian).string()),
            std::string::npos) << read_text(dir / "debian.log");

  // A case with effects of the pump's network switched on.
  std::filesystem::copy(reference_case_path().parent_path() / "thesis-resistance.csv", dir);
  write_file_atomic(dir / "effects.toml",
                    replace(replace(replace(reference_text(), "free_air_fraction = 0.0", "free_air_fraction = 0.002"),
                                    "leak_area_m2 = 0.0 ", "leak_area_m2 = 2e-9 "),
                            "orifice_discharge_coefficient = 0.0", "orifice_discharge_coefficient = 0.6"));
  const std::vector<std::string> runs = {
    "simulate --scenario loaded --frequency 200 --cycles 3",
    "simulate --scenario no-flow --frequency 100 --cycles 3",
    "simulate --scenario loaded --frequency 150 --cycles 3 --case " + (dir / "effects.toml").string(),
    "sweep --scenario loaded --from 50 --to 2000 --n 4 --series dynamic --quiet"};
  for (std::size_t i = 0; i < runs.size(); ++i)
    {
      const auto a = dir / ("built-" + std::to_string(i)), b = dir / ("debian-" + std::to_string(i));
      ASSERT_EQ(run(tool + " " + runs[i] + " --out " + a.string(), dir / "a.log"), 0) << read_text(dir / "a.log");
      ASSERT_EQ(run(as_debian + tool + " " + runs[i] + " --out " + b.string(), dir / "b.log"), 0)
        << read_text(dir / "b.log");
      // summary.json's numbers (every double written to round-trip), the
      // CVODE counters among them, without the times
      // (the difference as a JSON patch: what moved, not both summaries)
      EXPECT_EQ(nlohmann::json::diff(timeless(nlohmann::json::parse(read_text(a / "summary.json"))),
                                     timeless(nlohmann::json::parse(read_text(b / "summary.json")))),
                nlohmann::json::array())
        << runs[i];
      for (const char *table : {"timeseries.csv", "sweep.csv"})
        if (std::filesystem::exists(a / table))
          {
            EXPECT_TRUE(read_text(a / table) == read_text(b / table)) << runs[i] << ": " << table << " differs";
          }
      if (std::filesystem::exists(a / "sweep-runs.csv"))
        { // every column but the wall time: states, CVODE counters
          const auto ra = read_text(a / "sweep-runs.csv");
          ASSERT_NE(ra.find(",wall_time_s,"), std::string::npos) << ra;
          EXPECT_TRUE(csv_without_columns(ra, is_clock_key) ==
                      csv_without_columns(read_text(b / "sweep-runs.csv"), is_clock_key))
            << runs[i] << ": sweep-runs.csv differs";
        }
    }
  std::filesystem::remove_all(dir);
}
