// Helpers for tests that run the `rectify` tool and edit case files.
#pragma once

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include "common/case_file.h"

namespace rectify::test_support
{
  struct Command
  {
    int         exit_code;
    std::string output;
  };

  /// A file's whole text ("" where it cannot be read)
  inline std::string read_text(const std::filesystem::path &file)
  {
    std::ifstream     in(file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  inline Command rectify_cli(const std::string &args)
  {
    const auto  log = std::filesystem::temp_directory_path() /
                     ("rectify_cli_" + std::to_string(::getpid()) + ".log"); // ctest runs tests in parallel
    const std::string cmd = std::string(RECTIFY_BINARY) + " " + args + " > " + log.string() + " 2>&1";
    const int   status = std::system(cmd.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(log)};
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

  /// A coarse flow mesh (direct solver: the -np 1 / -np 2 comparisons are
  /// exact) and a coarse reed; openings 10-300 um at `tolerance` (relative
  /// interpolation error) from 3 to start (tests of design and whatif).
  inline std::string coarse_valve_case(const std::string &tolerance)
  {
    return "[mesh]\nsize_reed_m = 0.5e-3\nsize_far_m = 1.5e-3\nstation_spacing_m = 0.4e-3\n"
           "gap_layers = 2\nreed_layers = 1\nabove_layers = 1\nport_layer_m = 1e-3\n"
           "[flow]\nsolver = \"direct\"\n"
           "[stiffness]\ncells_along_length = 12\ncells_across_width = 10\n"
           "cells_through_thickness = 1\nn_modes = 1\n"
           "[design]\nopenings_from_m = 10e-6\nopenings_to_m = 300e-6\ninitial_openings = 3\n"
           "tolerance = " + tolerance + "\n";
  }

  inline std::string reference_text() { return read_text(reference_case_path()); }

  inline std::string replace(std::string text, const std::string &from, const std::string &to)
  {
    const auto pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    return text.replace(pos, from.size(), to);
  }

  /// `j` without every key that `drop(key)` names, at any depth (inside
  /// arrays too): two outputs compared apart from what the clock measured.
  template <class Drop>
  void erase_keys(nlohmann::json &j, const Drop &drop)
  {
    if (j.is_object())
      {
        for (auto it = j.begin(); it != j.end();)
          if (drop(it.key()))
            it = j.erase(it);
          else
            erase_keys(*it++, drop);
      }
    else if (j.is_array())
      for (auto &e : j)
        erase_keys(e, drop);
  }

  /// A CSV's comment lines, then its header and rows without the columns
  /// whose header cell `drop` names; the rows below the header sorted if
  /// `any_order` (a checkpoint: rows in the order they finished).
  template <class Drop>
  std::vector<std::string> csv_without_columns(const std::string &text, const Drop &drop, bool any_order = false)
  {
    std::vector<std::string> comments, rows;
    std::vector<bool>        dropped;
    std::istringstream       in(text);
    for (std::string line; std::getline(in, line);)
      {
        if (!line.empty() && line[0] == '#')
          {
            comments.push_back(line);
            continue;
          }
        std::vector<std::string> cells;
        std::stringstream        s(line);
        for (std::string c; std::getline(s, c, ',');)
          cells.push_back(c);
        if (dropped.empty())
          for (const auto &c : cells)
            dropped.push_back(drop(c));
        std::string kept;
        for (std::size_t i = 0; i < cells.size(); ++i)
          if (i >= dropped.size() || !dropped[i])
            kept += cells[i] + ",";
        rows.push_back(kept);
      }
    if (any_order && rows.size() > 1)
      std::sort(rows.begin() + 1, rows.end());
    comments.insert(comments.end(), rows.begin(), rows.end());
    return comments;
  }
} // namespace rectify::test_support
