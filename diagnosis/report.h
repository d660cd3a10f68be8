// The diagnosis's report (its last stage): what a diagnosis leaves in its
// folder for the user, written from the result as data (DiagnosisResult):
// the new case file with the named effects (read back and simulated: a case
// that does not reproduce the refit is not left behind), an overlay per run
// (CSV and PNG), candidates.csv, report.md and summary.json.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "common/case_file.h"
#include "diagnosis/diagnose.h"

namespace rectify::diagnosis
{
  /// What the report says about the inputs, as the command was given them.
  struct ReportInputs
  {
    std::string              case_path;  ///< as given
    std::string              case_file;  ///< the case file read (its text is edited into the new one)
    std::string              scenario;   ///< "no-flow" or "loaded"
    std::vector<std::string> data;       ///< the records' paths
    BaselineSecondMode       second_mode; ///< the reeds' second mode in the baseline
    double                   file_second_mode_Hz = 0; ///< the case file's own
    system::SystemParameters case_parameters;          ///< as diagnosed (second mode set)
    DiagnoseOptions          options;
    std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
    /// Reads a case file as the command does (every stage's keys checked):
    /// the new case file is read back with it
    std::function<CaseFile(const std::filesystem::path &)> load_case = [](const std::filesystem::path &path) {
      return CaseFile::load(path);
    };
  };

  /// Writes the report into `out` (each file whole: written to a temporary
  /// and renamed); `made_out`: the folder was made for this run (removed if
  /// left empty by a failure). Returns the new case file's name.
  std::string write_report(const DiagnosisResult &result, const std::vector<RunCase> &runs,
                           const system::ValveMaps &map, const ReportInputs &in, const std::filesystem::path &out,
                           bool made_out);
} // namespace rectify::diagnosis
