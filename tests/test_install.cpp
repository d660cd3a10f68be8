// The installed tool (`cmake --install`): it runs from any folder, finds its
// reference case under the install prefix (not in the source tree), and says
// which version, revision and libraries it was built with.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/cli_helpers.h"

using namespace rectify;
using namespace rectify::test_support;

namespace
{
  int run(const std::string &command, const std::filesystem::path &log)
  {
    return std::system((command + " > " + log.string() + " 2>&1").c_str());
  }

  std::string read(const std::filesystem::path &path)
  {
    std::ifstream     in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
} // namespace

TEST(Install, TheInstalledToolRunsFromAnyFolderOnItsOwnReferenceCase)
{
  const auto dir    = scratch("install");
  const auto prefix = dir / "prefix";
  ASSERT_EQ(run("cmake --install " + std::string(RECTIFY_BUILD_DIR) + " --prefix " + prefix.string(), dir / "install.log"),
            0)
    << read(dir / "install.log");
  const auto tool = prefix / "bin" / "rectify";
  ASSERT_TRUE(std::filesystem::exists(tool));
  EXPECT_TRUE(std::filesystem::exists(prefix / "share" / "rectify" / "cases" / "reference.toml"));
  EXPECT_TRUE(std::filesystem::exists(prefix / "share" / "rectify" / "cases" / "thesis-resistance.csv"));
  EXPECT_TRUE(std::filesystem::exists(prefix / "share" / "doc" / "rectify" / "map-sets.md"));

  // From another folder, without --case: the installed reference case.
  const auto elsewhere = dir / "elsewhere";
  std::filesystem::create_directories(elsewhere);
  const std::string in_elsewhere = "cd " + elsewhere.string() + " && env -u RECTIFY_DATA_DIR " + tool.string();
  ASSERT_EQ(run(in_elsewhere + " check --out check", dir / "check.log"), 0) << read(dir / "check.log");
  std::ifstream check_in(elsewhere / "check" / "summary.json");
  const auto    check = nlohmann::json::parse(check_in);
  const auto    used  = check["case"].get<std::string>();
  EXPECT_EQ(used.rfind(prefix.string(), 0), 0u) << "the installed tool used " << used;
  ASSERT_GE(check["default_case_search"].size(), 2u);
  EXPECT_EQ(check["default_case_search"][0]["path"].get<std::string>().rfind(prefix.string(), 0), 0u);
  EXPECT_TRUE(check["default_case_search"][0]["exists"].get<bool>());
  EXPECT_NE(read(dir / "check.log").find("looked for in this order"), std::string::npos);

  // A short simulation from there, on the installed case and its R(x) map.
  ASSERT_EQ(run(in_elsewhere + " simulate --scenario no-flow --frequency 50 --cycles 1 --out sim", dir / "sim.log"), 0)
    << read(dir / "sim.log");
  std::ifstream sim_in(elsewhere / "sim" / "summary.json");
  const auto    sim = nlohmann::json::parse(sim_in);
  EXPECT_GT(sim["stored_pressure_Pa"].get<double>(), 0);
  for (const char *library : {"rectify", "revision", "deal.II", "PETSc", "SUNDIALS", "TetGen", "CGAL"})
    EXPECT_FALSE(sim["build"][library].get<std::string>().empty()) << library;

  // --version: the version, the revision and the libraries.
  ASSERT_EQ(run(tool.string() + " --version", dir / "version.log"), 0);
  const auto version = read(dir / "version.log");
  for (const char *word : {"rectify " RECTIFY_VERSION, "revision", "deal.II", "PETSc", "SUNDIALS", "TetGen", "CGAL"})
    EXPECT_NE(version.find(word), std::string::npos) << version;
  std::filesystem::remove_all(dir);
}
