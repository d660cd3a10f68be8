// A new case file: the original's text with some keys set (replaced where
// the original sets them, else added under their table), each marked with a
// comment; relative paths of the original made absolute so that the new file
// works from any folder.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace rectify
{
  struct CaseEntry
  {
    /// value as TOML text ("1.5e-3", "\"on\""); empty: the original's line
    /// is commented out (and nothing added where it has none). key may be a
    /// quoted one's text ([uncertain] "lines.diameter_m").
    std::string table, key, value;
    std::string comment;
  };

  /// The edited text. `base_dir` resolves the original's relative paths
  /// (valves.resistance_map and the map sets, reed.properties_map,
  /// drive.waveform, mesh.shape_table, the outlines' CSV files). An entry's
  /// table is a plain table ([geometry]); keys under an array of tables
  /// ([[port]]) are left as they are.
  std::string edit_case_text(const std::string &text, const std::filesystem::path &base_dir,
                             const std::vector<CaseEntry> &entries);
} // namespace rectify
