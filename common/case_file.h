// Case files: one TOML format for the whole tool.
//
// Every parameter has its unit in its key ("stiffness_N_per_m"), is declared
// with its default and admissible range where it is read (one parameter struct
// per concern), and is range-checked there. Keys the program does not know are
// an error, named with file, table and line, so a typo never silently falls
// back to a default.
#pragma once

#include <array>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace rectify
{
  /// Bad input: a file, key or value the user can fix. The message names them.
  class InputError : public std::runtime_error
  {
  public:
    using std::runtime_error::runtime_error;
  };

  /// Admissible range of a real parameter. NaN and infinities are never admissible.
  struct Bounds
  {
    double min           = -std::numeric_limits<double>::max();
    double max           = std::numeric_limits<double>::max();
    bool   min_inclusive = true;
    bool   max_inclusive = true;

    static Bounds positive() { return {0.0, std::numeric_limits<double>::max(), false, true}; }
    static Bounds non_negative() { return {0.0, std::numeric_limits<double>::max(), true, true}; }
    static Bounds unit_interval() { return {0.0, 1.0, true, true}; }
    static Bounds closed(double lo, double hi) { return {lo, hi, true, true}; }
    static Bounds open(double lo, double hi) { return {lo, hi, false, false}; }

    bool        contains(double value) const;
    std::string describe() const;
  };

  class CaseFile
  {
  public:
    /// Reads and parses a TOML case file; throws InputError naming the file and line.
    static CaseFile load(const std::filesystem::path &path);
    /// Parses TOML text; `name` stands for the file in messages, paths resolve
    /// against `base_dir`.
    static CaseFile parse(const std::string &text, const std::string &name,
                          const std::filesystem::path &base_dir = ".");

    const std::string &name() const { return name_; }
    /// A path given in the case file, relative to the case file's folder.
    std::filesystem::path resolve(const std::string &path_in_file) const;

    bool has(const std::string &table, const std::string &key) const;
    /// The keys of [table] in file order (empty if there is no such table).
    std::vector<std::string> keys(const std::string &table) const;

    /// A real parameter: the value in the file, else `default_value`; both are
    /// checked against `bounds`.
    double real(const std::string &table, const std::string &key, double default_value,
                const Bounds &bounds) const;
    /// A list of real parameters (a TOML array of numbers), each checked.
    std::vector<double> reals(const std::string &table, const std::string &key,
                              const std::vector<double> &default_value, const Bounds &bounds) const;
    /// A whole-number parameter in [min, max].
    long integer(const std::string &table, const std::string &key, long default_value, long min,
                 long max) const;
    /// A string parameter; if `allowed` is not empty the value must be one of them.
    std::string text(const std::string &table, const std::string &key,
                     const std::string &default_value,
                     const std::vector<std::string> &allowed = {}) const;

    /// A list of points (a TOML array of [x, y] pairs), each coordinate
    /// checked against `bounds`; empty if the key is absent.
    std::vector<std::array<double, 2>> points(const std::string &table, const std::string &key,
                                              const Bounds &bounds) const;

    /// Arrays of tables: `[[port]]` entries are the tables "port#1",
    /// "port#2", ... for every accessor above; this is how many there are
    /// (0 if none). A `[name]` table instead of `[[name]]` is an InputError.
    std::size_t table_count(const std::string &array_name) const;

    /// Declares a key as known without reading it (for keys another stage reads).
    void declare(const std::string &table, const std::string &key) const;

    /// Throws InputError for the first key (or table) in the file that no
    /// parameter struct has read or declared. Call once every struct is read.
    void check_all_keys_known() const;

    /// A key some stage read, with its value (the file's or the default) and
    /// its admissible range as the reader states it.
    struct KeyRecord
    {
      std::string table, key, value, range;
      bool        given; ///< in the file (else the default)
    };
    /// Every key read so far, sorted by table and key: `rectify check` lists
    /// them (keys.csv), and a test checks each has a stated range.
    std::vector<KeyRecord> read_keys() const;

    /// The admissible range a real key was read with (real()), or nullptr
    /// if no stage has read it as a real yet: a range declared elsewhere for
    /// that key ([uncertain]) must lie inside it.
    const Bounds *bounds_read(const std::string &table, const std::string &key) const;

    /// "file [table] key" for messages.
    std::string where(const std::string &table, const std::string &key) const;

  private:
    struct Impl;
    explicit CaseFile(std::shared_ptr<const Impl> impl);
    std::shared_ptr<const Impl> impl_;
    std::string                 name_;
    std::filesystem::path       base_dir_;
    mutable std::set<std::string> known_; // "table.key"
    mutable std::map<std::string, KeyRecord> read_; // "table.key"
    mutable std::map<std::string, Bounds>    real_bounds_; // "table.key", as real() read it
    void record(const std::string &table, const std::string &key, const std::string &value,
                const std::string &range) const;
  };

  /// Where the reference case (the default --case) is looked for, in order:
  /// $RECTIFY_DATA_DIR/cases/, the installed PREFIX/share/rectify/cases/
  /// beside the running binary's PREFIX/bin/, and the source tree the binary
  /// was built from (a build-tree run).
  std::vector<std::filesystem::path> reference_case_search_path();
  /// The first of those that exists (else the first, for the error message).
  std::filesystem::path reference_case_path();

  /// Formats a double the way messages and summaries print it (shortest round trip).
  std::string format_number(double value);
} // namespace rectify
