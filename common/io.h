// Output that is never half-written: every file goes to a temporary sibling and
// is renamed into place once complete.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

namespace rectify
{
  /// Writes `content` to `path` through a temporary file and an atomic rename.
  void write_file_atomic(const std::filesystem::path &path, const std::string &content);

  /// Writes pretty-printed JSON atomically.
  void write_json(const std::filesystem::path &path, const nlohmann::json &value);

  /// Creates the output folder (and parents); a clear error if it cannot.
  void ensure_directory(const std::filesystem::path &dir);

  /// The time now in UTC, ISO 8601 to the second ("2026-11-24T07:33:20Z"): provenance and logs.
  std::string utc_now();

  /// A 64-bit FNV-1a hash of `content`, as 16 hex digits: detects a changed
  /// table or setting (provenance), not a tampered one.
  std::string content_hash(const std::string &content);
  /// content_hash of a file's bytes; InputError naming the file if it cannot be read.
  std::string file_hash(const std::filesystem::path &path);

  /// One CSV row: the values at full precision (%.17g), comma-separated, no newline.
  std::string csv_row(std::span<const double> values);

  /// A table of named real columns, written as CSV with a header line.
  class CsvTable
  {
  public:
    explicit CsvTable(std::vector<std::string> column_names);
    /// Precondition: row.size() == number of columns.
    void                            add_row(std::span<const double> row);
    std::size_t                     n_rows() const { return n_rows_; }
    const std::vector<std::string> &columns() const { return names_; }
    std::vector<double>             column(const std::string &name) const;
    std::string                     to_string() const;
    void                            write(const std::filesystem::path &path) const;

  private:
    std::vector<std::string> names_;
    std::vector<double>      values_; // row-major
    std::size_t              n_rows_ = 0;
  };

  /// Parses a numeric CSV with a header row. Lines starting with '#' are
  /// comments and returned in `comments` (without the '#'). Throws InputError
  /// naming file, row and column for anything malformed or non-finite.
  struct CsvData
  {
    std::vector<std::string>         columns;
    std::vector<std::vector<double>> rows;
    std::vector<std::string>         comments;
    std::size_t                      column_index(const std::string &name,
                                                  const std::string &file) const;
  };
  CsvData read_csv(const std::filesystem::path &path);
  CsvData parse_csv(const std::string &text, const std::string &name);
} // namespace rectify
