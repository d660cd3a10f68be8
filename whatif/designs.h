// The designs of a what-if batch: a grid (`--vary table.key=FROM:TO:N`, the
// product of every --vary) or a table (`--designs designs.csv`: a row per
// design, a column per case key, an optional "name" column). Each design is
// the base case with those keys set (common/case_edit.h). Reading them
// checks the syntax; `rectify whatif` then reads each design's case as every
// stage does (unknown keys, ranges, the geometry) before any job runs.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/case_edit.h"

namespace rectify::whatif
{
  /// One --vary: `table.key=FROM:TO:N`, N values evenly spaced (linear; with
  /// a trailing ":log", geometrically). N = 1 needs FROM = TO.
  struct Variation
  {
    std::string         table, key;
    std::vector<double> values;
    std::string         spec; ///< as given, for messages
    std::string         name() const { return table + "." + key; }
  };
  /// InputError naming the spec for anything malformed: no '=', a key not of
  /// the form table.key, a number that is not finite, N < 1, FROM > TO,
  /// log spacing through zero.
  Variation parse_variation(const std::string &spec);

  struct Design
  {
    std::string              name;    ///< d01, d02, ... or the table's "name" column
    std::vector<CaseEntry>   entries; ///< the keys set, values as TOML text
    std::vector<std::string> text_values; ///< as given (the table's cells, or the grid's numbers)
    /// {"table.key": value, ...}: numbers as numbers, the rest as text.
    nlohmann::json values() const;
  };

  /// The product of the variations, the first varying slowest.
  std::vector<Design> grid_designs(const std::vector<Variation> &variations);

  /// A designs table; InputError naming the file, row and column for a
  /// missing file, no key column, a key not of the form table.key, a row of
  /// the wrong length, an empty cell, a name given twice.
  std::vector<Design> read_designs_table(const std::filesystem::path &path);

  /// The case keys ("table.key") a set of designs sets, in first-seen order.
  std::vector<std::string> design_keys(const std::vector<Design> &designs);

  /// The base case's text with the design's keys set (relative paths made
  /// absolute against `base_dir`, the base case's folder).
  std::string design_case_text(const std::string &base_text, const std::filesystem::path &base_dir,
                               const Design &design);
} // namespace rectify::whatif
