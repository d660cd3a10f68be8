// Helpers for tests that run the `rectify` tool and edit case files.
#pragma once

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

#include "common/case_file.h"

namespace rectify::test_support
{
  struct Command
  {
    int         exit_code;
    std::string output;
  };

  inline Command rectify_cli(const std::string &args)
  {
    const auto  log = std::filesystem::temp_directory_path() /
                     ("rectify_cli_" + std::to_string(::getpid()) + ".log"); // ctest runs tests in parallel
    const std::string cmd = std::string(RECTIFY_BINARY) + " " + args + " > " + log.string() + " 2>&1";
    const int   status = std::system(cmd.c_str());
    std::ifstream in(log);
    std::stringstream s;
    s << in.rdbuf();
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, s.str()};
  }

  inline std::filesystem::path scratch(const std::string &name)
  {
    const auto dir = std::filesystem::temp_directory_path() / ("rectify_cli_" + name);
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
  }

  /// `rectify diagnose --data DATA ARGS --out OUT`: OUT/summary.json, or
  /// null (with the command's output as a test failure) if it fails.
  inline nlohmann::json diagnose_summary(const std::filesystem::path &data, const std::string &args,
                                         const std::filesystem::path &out)
  {
    const auto r = rectify_cli("diagnose --data " + data.string() + " " + args + " --out " + out.string());
    if (r.exit_code != 0)
      {
        ADD_FAILURE() << r.output;
        return {};
      }
    return nlohmann::json::parse(std::ifstream(out / "summary.json"));
  }

  /// "mpirun -np N " for a command line. This test program runs under MPI
  /// itself (a singleton): mpirun must not see its environment.
  inline std::string mpirun(int n)
  {
    return "for v in $(env | grep -o '^\\(OMPI\\|PMIX\\|OPAL\\)[A-Za-z0-9_]*'); do unset $v; done; "
           "mpirun --allow-run-as-root --oversubscribe -np " +
           std::to_string(n) + " ";
  }

  inline std::string reference_text()
  {
    std::ifstream     in(reference_case_path());
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  inline std::string replace(std::string text, const std::string &from, const std::string &to)
  {
    const auto pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    return text.replace(pos, from.size(), to);
  }
} // namespace rectify::test_support
