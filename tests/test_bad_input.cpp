// Bad input refused before any work (issue 16): every numeric option checked
// for its type, every output folder tried before the work, the option
// parser's errors as exit code 2, and case keys that were accepted and
// ignored or ended in a solver failure.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "common/case_file.h"
#include "common/io.h"
#include "fuzz/fuzz_targets.h"
#include "system/parameters.h"
#include "tests/cli_helpers.h"

using namespace rectify;
using namespace rectify::test_support;

namespace
{
  /// Runs `args`, expects exit code 2, every word of `named` in the message,
  /// and no output folder `out` left behind.
  void expect_refused(const std::string &args, const std::vector<std::string> &named,
                      const std::filesystem::path &out)
  {
    const auto r = rectify_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    for (const auto &word : named)
      EXPECT_NE(r.output.find(word), std::string::npos) << args << ": '" << word << "' not in\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << args;
  }
} // namespace

TEST(BadInput, NumericOptionsAreCheckedForTheirType)
{
  const auto dir = scratch("bad_numbers");
  const auto out = dir / "out";
  const std::string o = " --out " + out.string();
  // A negative count is not read as 2^64 - 3 (it ran until killed).
  expect_refused("simulate --cycles -3" + o, {"--cycles", "-3", "whole number"}, out);
  expect_refused("synth --cycles -1" + o, {"--cycles", "-1"}, out);
  expect_refused("sweep --n -2" + o, {"--n", "-2"}, out);
  // NaN and infinities are refused, not taken for "not given".
  expect_refused("simulate --current-pp nan" + o, {"--current-pp", "nan", "finite"}, out);
  expect_refused("simulate --current-bias NaN" + o, {"--current-bias"}, out);
  expect_refused("simulate --rtol inf" + o, {"--rtol", "inf", "finite"}, out);
  // The currents' ranges (those of [drive]): a current in mA is refused.
  expect_refused("simulate --current-bias 5000" + o, {"--current-bias", "5000", "[-1000, 1000]"}, out);
  expect_refused("sweep --current-pp 20000 --n 2 --from 10 --to 20" + o, {"--current-pp", "20000", "[0, 2000]"}, out);
  expect_refused("synth --current-pp -1" + o, {"--current-pp", "-1"}, out);
  expect_refused("synth --drive-noise -0.5" + o, {"--drive-noise", "-0.5"}, out);
  expect_refused("synth --cycles 100000 --samples-per-cycle 1000" + o, {"10^7 samples"}, out);
  expect_refused("sweep --max-startup-cycles 0 --n 2 --from 10 --to 20" + o, {"--max-startup-cycles"}, out);
  expect_refused("simulate --frequency 12abc" + o, {"--frequency", "12abc", "not a number"}, out);
  // The parser's own errors: exit 2 (was 104-114), and an unknown command named.
  expect_refused("simulate --no-such-option 1" + o, {"--no-such-option"}, out);
  expect_refused("simulate --frequency 10 --frequency 20" + o, {"--frequency"}, out);
  expect_refused("simulat" + o, {"unknown command 'simulat'", "simulate"}, out);
  expect_refused("stokes --flow-rate 0 --opening 100um" + o, {"--flow-rate", "positive"}, out);
  expect_refused("stokes --flow-rate nan --opening 100um" + o, {"--flow-rate"}, out);
  // --help and --version are not errors.
  EXPECT_EQ(rectify_cli("--version").exit_code, 0);
  EXPECT_EQ(rectify_cli("simulate --help").exit_code, 0);
}

TEST(BadInput, AnOutputFolderThatCannotBeWrittenIsFoundBeforeAnyWork)
{
  const auto dir = scratch("bad_out");
  // diagnose ran every fit (minutes) before finding this.
  expect_refused("diagnose --data " + (dir / "none.csv").string() + " --frequency 10 --out /proc/nonexistent/d",
                 {"--out", "/proc/nonexistent/d"}, "/proc/nonexistent/d");
  write_file_atomic(dir / "a-file", "x\n");
  const auto r = rectify_cli("simulate --out " + (dir / "a-file").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("not a folder"), std::string::npos) << r.output;
  // The check leaves nothing behind: the folder appears with the results.
  const auto nested = dir / "new" / "deeper";
  ASSERT_EQ(rectify_cli("simulate --cycles 0 --out " + nested.string()).exit_code, 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "new"));
  for (const auto &entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".rectify-write-test"), std::string::npos);
}

TEST(BadInput, CaseKeysThatWereIgnoredOrCrashedTheSolverAreRefused)
{
  const auto dir = scratch("bad_keys");
  const auto out = dir / "out";
  const auto run = [&](const std::string &name, const std::string &text) {
    write_file_atomic(dir / name, text);
    return "simulate --case " + (dir / name).string() + " --out " + out.string();
  };
  // Accepted and ignored before.
  expect_refused(run("t.toml", "[reed]\nproperties_thickness_m = 1e-4\n"),
                 {"t.toml", "[reed] properties_thickness_m", "properties_map"}, out);
  // A CVODE failure before: a reed mode no step can resolve.
  expect_refused(run("k.toml", "[reed]\nstiffness_N_per_m = 1e30\n"),
                 {"k.toml", "[reed] stiffness_N_per_m", "1e+30", "natural frequency"}, out);
  // The case file and the key that named the missing map.
  expect_refused(run("m.toml", "[valves]\nresistance_map = \"no-such-map.csv\"\n"),
                 {"m.toml", "[valves] resistance_map", "no-such-map.csv", "no such file"}, out);
  // A reed whose frequency is high but resolvable is accepted (the check is
  // not a blanket limit on the stiffness).
  const CaseFile ok = CaseFile::parse("[reed]\nstiffness_N_per_m = 1e6\n", (dir / "ok.toml").string());
  EXPECT_NO_THROW(system::ReedParameters::from_case(ok));
}

TEST(BadInput, AStopACavitationPressureAndFatigueDataTheHardwareCannotHaveAreRefused)
{
  const auto dir = scratch("bad_limits");
  const auto out = dir / "out";
  const auto run = [&](const std::string &name, const std::string &text) {
    write_file_atomic(dir / name, text);
    return "simulate --case " + (dir / name).string() + " --out " + out.string();
  };
  // the stop above the pocket's ceiling, or below the closed reed's top
  expect_refused(run("s1.toml", "[geometry]\nstop_height_m = 2.5e-3\n"),
                 {"s1.toml", "[geometry] stop_height_m", "0.0025", "ceiling"}, out);
  expect_refused(run("s2.toml", "[geometry]\nstop_height_m = 0.1e-3\n"),
                 {"s2.toml", "[geometry] stop_height_m", "0.0001", "closed reed"}, out);
  // an endurance limit of zero or above the ultimate strength
  expect_refused(run("e1.toml", "[reed_material]\nendurance_limit_Pa = 0\n"),
                 {"e1.toml", "[reed_material] endurance_limit_Pa"}, out);
  expect_refused(run("e2.toml", "[reed_material]\nendurance_limit_Pa = 600e6\nultimate_strength_Pa = 515e6\n"),
                 {"e2.toml", "[reed_material] endurance_limit_Pa", "6e+08", "ultimate"}, out);
  // a cavitation pressure at or above the bias pressure
  expect_refused(run("c.toml", "[fluid]\ncavitation_pressure_Pa = 3e6\n"),
                 {"c.toml", "[fluid] cavitation_pressure_Pa", "3e+06", "bias"}, out);
  expect_refused(run("r.toml", "[reed]\nstop_restitution = 1.0\n"), {"r.toml", "[reed] stop_restitution"}, out);
  expect_refused(run("o.toml", "[reed]\nstop = \"maybe\"\n"), {"o.toml", "[reed] stop", "maybe"}, out);
  // the ceiling itself is a stop
  const auto thesis_map = (reference_case_path().parent_path() / "thesis-resistance.csv").string();
  const auto ok = rectify_cli(run("ok.toml", "[geometry]\nstop_height_m = 2.0e-3\n[valves]\nresistance_map = \"" +
                                             thesis_map + "\"\n") + " --cycles 1");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(BadInput, EffectsThatCannotActAndOpeningsTheMeshCannotResolveAreRefused)
{
  const auto dir = scratch("bad_runs");
  const auto out = dir / "out";
  // Friction on an output piston that a no-flow run holds still: the record
  // would carry an "answer" its data cannot show.
  expect_refused("synth --effect piston_friction --scenario no-flow --out " + out.string(),
                 {"piston_friction", "no-flow"}, out);
  // 1e-12 m meshed with dihedral angles of 0 degrees and an aspect ratio of 4.6e9.
  expect_refused("mesh --opening 1e-12 --out " + out.string(), {"1e-12", "smallest opening", "6e-08"}, out);
  EXPECT_EQ(rectify_cli("mesh --opening 2um --no-files --out " + out.string()).exit_code, 0);
}

TEST(BadInput, ACsvCutOffInsideItsLastLineIsRefused)
{
  // "1.2345" cut to "1.23" still reads as a number: the missing line end is
  // what shows the file was cut.
  try
    {
      parse_csv("time_s,current_A\n0,1\n0.001,1.23", "d.csv");
      ADD_FAILURE() << "a cut-off last line was accepted";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("'d.csv' line 3"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("cut off"), std::string::npos) << e.what();
    }
  EXPECT_NO_THROW(parse_csv("time_s,current_A\n0,1\n0.001,1.2345\n", "d.csv"));
  EXPECT_NO_THROW(parse_csv("time_s,current_A\n0,1\n# a comment at the end, no line end", "d.csv"));
  // Through the tool: the drive-current file of a simulation.
  const auto dir = scratch("bad_csv");
  write_file_atomic(dir / "cut.csv", "time_s,current_A\n0,1\n0.05,2\n0.1,1.5");
  const auto out = dir / "out";
  expect_refused("simulate --frequency 10 --cycles 1 --current-csv " + (dir / "cut.csv").string() + " --out " +
                   out.string(),
                 {"cut.csv", "line 4", "cut off"}, out);
}

// Every input the fuzzers start from (fuzz/corpus/<target>) and every one
// they found a fault with (fuzz/regressions/<target>) through the same calls
// as the fuzz targets (fuzz/fuzz_targets.h): refused with InputError or
// read, nothing else. The first finding: a case file with a '...' string
// that is not UTF-8, on which toml11 3.7 read past its buffer; it is now
// refused before toml11 sees it, naming the line and byte.
TEST(BadInput, EveryFuzzInputIsReadOrRefusedCleanly)
{
  const std::filesystem::path fuzz = std::filesystem::path(RECTIFY_SOURCE_DIR) / "fuzz";
  using Target = void (*)(const std::uint8_t *, std::size_t);
  const std::vector<std::pair<std::string, Target>> targets{{"case_file", rectify::fuzz::case_file},
                                                            {"measured_run", rectify::fuzz::measured_run},
                                                            {"maps", rectify::fuzz::maps},
                                                            {"drive", rectify::fuzz::drive}};
  int replayed = 0;
  for (const auto &[name, target] : targets)
    for (const char *kind : {"corpus", "regressions"})
      {
        const auto dir = fuzz / kind / name;
        if (!std::filesystem::is_directory(dir))
          continue;
        for (const auto &entry : std::filesystem::directory_iterator(dir))
          {
            std::ifstream     in(entry.path(), std::ios::binary);
            const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            EXPECT_NO_THROW(target(reinterpret_cast<const std::uint8_t *>(bytes.data()), bytes.size()))
              << entry.path();
            ++replayed;
          }
      }
  EXPECT_GE(replayed, 10);

  const auto crash = fuzz / "regressions" / "case_file" / "crash-33c172c003b0c22b9e52e3e980004e645eb3d4f1";
  std::ifstream     in(crash, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.size(), 176u);
  try
    {
      (void)CaseFile::parse(bytes, "crash.toml");
      ADD_FAILURE() << "accepted";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("line 1, byte 2 is not UTF-8"), std::string::npos) << e.what();
    }
  // UTF-8 itself is fine (a comment with a micro sign); overlong forms and
  // surrogates are not
  EXPECT_NO_THROW((void)CaseFile::parse("# 127 \xC2\xB5m\n[reed]\n", "ok.toml"));
  for (const std::string bad : {"a = 1\n# \xC0\xAF\n", "a = 1\n# \xED\xA0\x80\n", "a = '\xF5\x80\x80\x80'\n"})
    EXPECT_THROW((void)CaseFile::parse(bad, "bad.toml"), InputError) << bad;
}

namespace
{
  /// One line of a CSV whose text cells may be quoted ("a, b" and "" for ").
  std::vector<std::string> split_quoted(const std::string &line)
  {
    std::vector<std::string> cells(1);
    bool                     quoted = false;
    for (std::size_t i = 0; i < line.size(); ++i)
      {
        const char c = line[i];
        if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"')
          cells.back() += '"', ++i;
        else if (c == '"')
          quoted = !quoted;
        else if (c == ',' && !quoted)
          cells.emplace_back();
        else
          cells.back() += c;
      }
    return cells;
  }

  /// Values just outside a range as `CaseFile::read_keys` states it, in
  /// TOML; empty for a range with no outside (text).
  std::vector<std::string> outside(const std::string &range)
  {
    const auto number = [](double x, bool whole) {
      return whole ? std::to_string(static_cast<long long>(x)) : format_number(x) + (std::floor(x) == x ? ".0" : "");
    };
    const bool whole = range.rfind("whole number", 0) == 0;
    const bool each  = range.rfind("each ", 0) == 0;
    std::string r = each ? range.substr(5) : range;
    std::vector<std::string> values;
    if (r.rfind("one of", 0) == 0)
      return {"\"no-such-choice\""};
    if (r.rfind("> ", 0) == 0 || r.rfind(">= ", 0) == 0)
      {
        const double lo = std::stod(r.substr(r.find(' ') + 1));
        values.push_back(number(r[1] == '=' ? lo - std::max(1.0, std::abs(lo)) * (whole ? 1 : 1e-3) : lo, whole));
      }
    else if (r.rfind("< ", 0) == 0 || r.rfind("<= ", 0) == 0)
      {
        const double hi = std::stod(r.substr(r.find(' ') + 1));
        values.push_back(number(r[1] == '=' ? hi + std::max(1.0, std::abs(hi)) * 1e-3 : hi, whole));
      }
    else if (r.find('[') != std::string::npos || r.find('(') != std::string::npos)
      {
        const auto   open  = r.find_first_of("[(");
        const auto   comma = r.find(',', open);
        const auto   close = r.find_first_of("])", comma);
        const double lo = std::stod(r.substr(open + 1, comma - open - 1));
        const double hi = std::stod(r.substr(comma + 1, close - comma - 1));
        const double step = whole ? 1.0 : 1e-3 * std::max(std::abs(hi - lo), 1e-300);
        values.push_back(number(r[open] == '[' ? lo - step : lo, whole));
        values.push_back(number(r[close] == ']' ? hi + step : hi, whole));
      }
    if (each)
      for (auto &v : values)
        v = "[" + v + "]";
    return values;
  }

  /// `text` without the line that starts with `start`.
  std::string drop_line(const std::string &text, const std::string &start)
  {
    const auto at = text.find("\n" + start);
    EXPECT_NE(at, std::string::npos) << start;
    return at == std::string::npos ? text : text.substr(0, at) + text.substr(text.find('\n', at + 1));
  }

  /// The reference case with [table] key = value (replacing the key's line,
  /// or added under the table's header).
  std::string with_key(const std::string &text, const std::string &table, const std::string &key,
                       const std::string &value)
  {
    std::istringstream in(text);
    std::string        out, current, line;
    bool               done = false;
    const std::string  toml_key = key.find('.') == std::string::npos ? key : "\"" + key + "\"";
    while (std::getline(in, line))
      {
        const auto first = line.find_first_not_of(" \t");
        if (first != std::string::npos && line[first] == '[')
          {
            current = line.substr(first + 1, line.find(']') - first - 1);
            out += line + "\n";
            if (current == table && !done && text.find("\n" + toml_key + " ") == std::string::npos &&
                text.find("\n" + toml_key + "=") == std::string::npos)
              {
                out += toml_key + " = " + value + "\n";
                done = true;
              }
            continue;
          }
        if (!done && current == table && line.rfind(toml_key, 0) == 0 &&
            line.find_first_not_of(" =", toml_key.size()) > toml_key.size())
          {
            out += toml_key + " = " + value + "\n";
            done = true;
            continue;
          }
        out += line + "\n";
      }
    EXPECT_TRUE(done) << "[" << table << "] " << key << " not placed";
    return out;
  }
} // namespace

TEST(BadInput, EveryCaseKeyHasARangeAndAValueOutsideItIsRefusedNamingTheKey)
{
  // The audit of issue 16 as a test: `check` lists every key a stage reads
  // with its range (keys.csv). Each must state a range ("finite" alone is
  // none), and a case with any one key set just outside its range is refused
  // (exit 2) naming the table, the key and the value, with no output.
  const auto dir = scratch("bad_input_keys");
  auto       r   = rectify_cli("check --out " + (dir / "ok").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "ok" / "keys.csv");
  std::string   line;
  std::getline(in, line);
  ASSERT_EQ(line, "table,key,value,given,range");
  const std::string reference = reference_text();
  std::size_t       n_keys = 0, n_tried = 0;
  const std::set<std::string> text_keys{"drive.waveform", "reed.properties_map", "valves.inlet_map_set",
                                        "valves.map_set", "valves.outlet_map_set", "valves.resistance_map"};
  while (std::getline(in, line))
    {
      const auto cells = split_quoted(line);
      ASSERT_EQ(cells.size(), 5u) << line;
      const std::string &table = cells[0], &key = cells[1], &range = cells[4];
      ++n_keys;
      EXPECT_NE(range, "finite") << "[" << table << "] " << key << " has no stated range";
      if (range == "text")
        {
          // A file (or "sine"): a missing one is refused naming the key.
          EXPECT_TRUE(text_keys.count(table + "." + key)) << "[" << table << "] " << key << ": free text";
          // The reference case written elsewhere: its R(x) map by full path;
          // a map set or a reed map replaces the keys it gives.
          std::string base = replace(reference, "resistance_map = \"thesis-resistance.csv\"",
                                     "resistance_map = \"" +
                                       (reference_case_path().parent_path() / "thesis-resistance.csv").string() +
                                       "\"");
          if (key.find("map_set") != std::string::npos)
            base = drop_line(drop_line(base, "resistance_map = "), "interpolation = ");
          if (key == "properties_map")
            base = drop_line(drop_line(base, "stiffness_N_per_m = 6650"), "effective_mass_kg = 0.3643e-3");
          const auto case_file = dir / (table + "." + key + ".toml");
          write_file_atomic(case_file, with_key(base, table, key, "\"no-such-file.csv\""));
          expect_refused("check --case " + case_file.string() + " --out " + (dir / "out").string(),
                         {key, "no-such-file.csv"}, dir / "out");
          ++n_tried;
          continue;
        }
      for (const auto &value : outside(range))
        {
          SCOPED_TRACE("[" + table + "] " + key + " = " + value + " (range " + range + ")");
          const auto case_file = dir / (table + "." + key + ".toml");
          write_file_atomic(case_file, with_key(reference, table, key, value));
          expect_refused("check --case " + case_file.string() + " --out " + (dir / "out").string(), {key},
                         dir / "out");
          ++n_tried;
        }
    }
  EXPECT_GT(n_keys, 100u);
  EXPECT_GT(n_tried, n_keys);
  RecordProperty("keys", static_cast<int>(n_keys));
  RecordProperty("cases_tried", static_cast<int>(n_tried));
}
