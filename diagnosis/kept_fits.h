// The checkpoint of a diagnosis (DiagnoseOptions::checkpoint_dir): each
// candidate's fit kept the moment it ends, so that an interrupted diagnosis
// started again with the same fingerprint takes them instead of fitting
// those candidates again.
//
// Takes: the options (folder, fingerprint), the round's fits as they end.
// Gives: the fits an interrupted run of the same diagnosis kept. The fits of
// one round are independent of each other and of the cores they ran on: a
// kept fit and its predictions made again from its point are what fitting
// it again would give, to the last bit.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/checkpoint.h"
#include "diagnosis/options.h"
#include "diagnosis/results.h"

namespace rectify::diagnosis
{
  /// The fits DiagnoseOptions::checkpoint_dir holds (whole rows), and
  /// their removal (the diagnosis's results are written)
  std::size_t kept_fits(const std::filesystem::path &dir);
  void        remove_checkpoint(const std::filesystem::path &dir);
  /// After a diagnosis failed: if no fit was kept, its checkpoint goes, and
  /// the folder too where the diagnosis made it and left it empty (a
  /// failure before any fit leaves nothing behind).
  void        discard_if_nothing_kept(const std::filesystem::path &dir, bool made_dir);
  /// What makes a diagnosis's fits the same (DiagnoseOptions::checkpoint_fingerprint):
  /// the build, the command's settings (every option but the folder), the
  /// case file's and each record's content.
  nlohmann::json checkpoint_fingerprint(const std::string &settings, const std::filesystem::path &case_path,
                                        const std::vector<std::string> &data);

  class FitStore
  {
  public:
    /// Opens (or starts) the kept fits in o.checkpoint_dir; discards them
    /// where another diagnosis (fingerprint) kept them or they are
    /// unreadable; `say` gets one line for each such event.
    FitStore(const DiagnoseOptions &o, const std::function<void(const std::string &)> &say);

    /// The fit of `effect` kept in `round`, if any
    std::optional<CandidateResult> find(int round, const std::string &effect) const;

    /// Keeps a finished fit (thread-safe)
    void keep(int round, const CandidateResult &c);

    /// The round's none, fitted again: the kept fits stand only where the
    /// kept none is the same to the last bit (else the inputs differ in a
    /// way the fingerprint does not hold: a map set rewritten in place)
    void check_none(int round, const CandidateResult &none);

  private:
    void discard(const std::string &why);
    void open();

    std::filesystem::path                                  dir_;
    nlohmann::json                                         fingerprint_;
    std::function<void(const std::string &)>               say_;
    std::optional<Checkpoint>                              file_;
    std::map<std::pair<int, std::string>, CandidateResult> kept_;
  };
} // namespace rectify::diagnosis
