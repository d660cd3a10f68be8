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

  // The finite-element commands, through the front end, from rectify-fe.
  EXPECT_TRUE(std::filesystem::exists(prefix / "bin" / "rectify-fe"));
  ASSERT_EQ(run(in_elsewhere + " map-stiffness --help", dir / "fe.log"), 0) << read(dir / "fe.log");
  EXPECT_NE(read(dir / "fe.log").find("--thickness"), std::string::npos) << read(dir / "fe.log");
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
  const auto front = read(dir / "front.log"), back = read(dir / "fe.log");
  for (const char *library : {"libdeal.ii", "libpetsc", "libmpi", "libtet", "libslepc", "libopenblas"})
    EXPECT_EQ(front.find(library), std::string::npos) << library << " in\n" << front;
  for (const char *library : {"libdeal.ii", "libtet"})
    EXPECT_NE(back.find(library), std::string::npos) << library << " not in\n" << back;
  EXPECT_NE(front.find("libsundials_cvode"), std::string::npos) << front;

  // An FE command given to the front end runs in rectify-fe with the same
  // arguments and exit code; the help names `rectify`.
  EXPECT_EQ(run(front_end.string() + " stokes --help", dir / "help.log"), 0);
  const auto help = read(dir / "help.log");
  EXPECT_NE(help.find("--flow-rate"), std::string::npos) << help;
  EXPECT_EQ(help.find("rectify-fe stokes"), std::string::npos) << help;
  const int status = run(front_end.string() + " stiffness --case " + (dir / "missing.toml").string() +
                          " --out " + (dir / "x").string(), dir / "bad.log");
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2) << read(dir / "bad.log");
  EXPECT_NE(read(dir / "bad.log").find("missing.toml"), std::string::npos) << read(dir / "bad.log");
  EXPECT_FALSE(std::filesystem::exists(dir / "x"));
  std::filesystem::remove_all(dir);
}
