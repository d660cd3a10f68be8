// Checkpoints of long runs made of independent items (sweep frequencies,
// thicknesses): every finished item is appended at once as one CSV row to
// DIR/NAME.csv, beside DIR/NAME.json holding the settings that produced them.
// Started again with the same settings, a run reads the finished rows and
// does only the rest; with other settings it refuses rather than mix them.
#pragma once

#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace rectify
{
  class Checkpoint
  {
  public:
    /// `header` is the CSV header line (without newline). Throws InputError
    /// if DIR holds a checkpoint of the same name made with other settings.
    Checkpoint(const std::filesystem::path &dir, const std::string &name,
               const nlohmann::json &fingerprint, const std::string &header);
    ~Checkpoint();
    Checkpoint(const Checkpoint &)            = delete;
    Checkpoint &operator=(const Checkpoint &) = delete;

    /// True where DIR holds a checkpoint NAME made with another fingerprint
    /// (or whose fingerprint cannot be read): the constructor would refuse it.
    static bool holds_other(const std::filesystem::path &dir, const std::string &name,
                            const nlohmann::json &fingerprint);

    /// The complete rows found when opening (a row cut off by a kill is dropped).
    const std::vector<std::string> &finished_rows() const { return rows_; }
    /// Appends one row (without newline) in one write. Thread-safe. Throws
    /// std::runtime_error naming the file if it cannot (a full disk).
    void append(const std::string &row);

  private:
    std::vector<std::string> rows_;
    std::filesystem::path    path_;
    int                      fd_ = -1;
    std::mutex               mutex_;
  };
} // namespace rectify
