// Case files, bad input and safe output (common/).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "common/case_file.h"
#include "common/io.h"
#include "common/plot.h"
#include "app/case_loading.h"
#include "system/parameters.h"

#include <tuple>
#include <vector>

using namespace rectify;

namespace
{
  /// Expects `f` to throw InputError whose message contains every fragment.
  template <typename F>
  void expect_input_error(F &&f, std::initializer_list<std::string> fragments)
  {
    try
      {
        f();
        ADD_FAILURE() << "no InputError thrown";
      }
    catch (const InputError &e)
      {
        for (const auto &frag : fragments)
          EXPECT_NE(std::string(e.what()).find(frag), std::string::npos)
            << "message '" << e.what() << "' lacks '" << frag << "'";
      }
  }

  CaseFile parse(const std::string &text) { return CaseFile::parse(text, "test.toml"); }
} // namespace

TEST(CaseFile, ReferenceCaseReadsWithEveryKeyKnown)
{
  EXPECT_NO_THROW(app::load_case(reference_case_path()));
  const auto p = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  // Spot checks against Table A.1 (converted from inches and ksi).
  EXPECT_NEAR(p.transducer.rod_stiffness_N_per_m(), 38.8e6, 0.005 * 38.8e6);
  EXPECT_NEAR(p.fluid.bulk_modulus_Pa, 85 * 6.894757e6, 1e3);
  EXPECT_DOUBLE_EQ(p.reed.stiffness_N_per_m, 6650.0);
}

TEST(CaseFile, DefaultsEqualTheReferenceCase)
{
  // An empty case file means the documented defaults, which are the reference case.
  const auto def = system::SystemParameters::from_case(parse("")).to_json();
  auto       ref = system::SystemParameters::from_case(CaseFile::load(reference_case_path())).to_json();
  auto       d   = def;
  d["valves"]["resistance_map"] = ref["valves"]["resistance_map"] = "";
  for (auto &[table, values] : ref.items())
    for (auto &[key, value] : values.items())
      {
        if (value.is_number())
          EXPECT_NEAR(d[table][key].get<double>(), value.get<double>(),
                      1e-4 * std::abs(value.get<double>()))
            << table << "." << key;
        else
          EXPECT_EQ(d[table][key], value) << table << "." << key;
      }
}

TEST(CaseFile, UnknownKeyIsNamedWithFileTableAndLine)
{
  const CaseFile file = parse("[reed]\nstiffness_N_per_m = 100\nstifness_N_per_m = 5\n");
  (void)system::SystemParameters::from_case(file);
  expect_input_error([&] { file.check_all_keys_known(); },
                     {"test.toml", "[reed]", "stifness_N_per_m", "line 3", "unknown key"});
}

TEST(CaseFile, UnknownTableIsAnError)
{
  const CaseFile file = parse("[reeds]\nstiffness_N_per_m = 100\n");
  (void)system::SystemParameters::from_case(file);
  expect_input_error([&] { file.check_all_keys_known(); }, {"unknown table [reeds]"});
}

TEST(CaseFile, OutOfRangeValuesNameKeyAndValue)
{
  expect_input_error([] { system::SystemParameters::from_case(parse("[reed]\neffective_mass_kg = -1\n")); },
                     {"[reed] effective_mass_kg", "-1", "must be > 0", "line 2"});
  expect_input_error([] { system::SystemParameters::from_case(parse("[chamber]\npiston_area_m2 = 0\n")); },
                     {"[chamber] piston_area_m2", "must be > 0"});
  expect_input_error([] { system::SystemParameters::from_case(parse("[cylinder]\nhigh_side_fraction = 1.0\n")); },
                     {"high_side_fraction", "in (0, 1)"});
}

TEST(CaseFile, NanAndInfinityAreRejected)
{
  expect_input_error([] { system::SystemParameters::from_case(parse("[reed]\nstiffness_N_per_m = nan\n")); },
                     {"stiffness_N_per_m", "nan"});
  expect_input_error([] { system::SystemParameters::from_case(parse("[load]\nmass_kg = inf\n")); },
                     {"mass_kg", "inf"});
}

TEST(CaseFile, WrongTypesAndChoicesAreRejected)
{
  expect_input_error([] { system::SystemParameters::from_case(parse("[reed]\nstiffness_N_per_m = \"stiff\"\n")); },
                     {"stiffness_N_per_m", "expected a number"});
  expect_input_error([] { system::SystemParameters::from_case(parse("[solver]\njacobian = \"numeric\"\n")); },
                     {"jacobian", "numeric", "'analytic'"});
}

TEST(CaseFile, MalformedAndMissingFiles)
{
  expect_input_error([] { parse("[reed\nstiffness = 1\n"); }, {"test.toml", "not valid TOML"});
  expect_input_error([] { CaseFile::load("/nonexistent/case.toml"); },
                     {"cannot open case file", "/nonexistent/case.toml"});
  expect_input_error([] { parse("stiffness = 1\n").check_all_keys_known(); },
                     {"must be a [table]"});
}

TEST(Io, AtomicWriteLeavesOnlyTheFinishedFile)
{
  const auto dir = std::filesystem::temp_directory_path() / "rectify_test_io";
  std::filesystem::remove_all(dir);
  ensure_directory(dir);
  write_file_atomic(dir / "a.txt", "hello\n");
  std::size_t n = 0;
  for (const auto &e : std::filesystem::directory_iterator(dir))
    {
      ++n;
      EXPECT_EQ(e.path().filename(), "a.txt");
    }
  EXPECT_EQ(n, 1u);
  std::ifstream in(dir / "a.txt");
  std::string   s;
  std::getline(in, s);
  EXPECT_EQ(s, "hello");
  std::filesystem::remove_all(dir);
}

TEST(Io, CsvErrorsNameFileLineAndColumn)
{
  expect_input_error([] { parse_csv("time_s,current_A\n0,1\n0.1,abc\n", "d.csv"); },
                     {"d.csv", "line 3", "current_A", "abc"});
  expect_input_error([] { parse_csv("time_s,current_A\n0,nan\n", "d.csv"); },
                     {"line 2", "not finite"});
  expect_input_error([] { parse_csv("time_s,current_A\n0,1,2\n", "d.csv"); },
                     {"line 2", "3 values for 2 columns"});
  const auto data = parse_csv("# comment\ntime_s,current_A\n0,1\n", "d.csv");
  EXPECT_EQ(data.rows.size(), 1u);
  expect_input_error([&] { data.column_index("voltage_V", "d.csv"); }, {"missing column 'voltage_V'"});
}

// A panel whose series have no number to draw (a what-if whose designs have
// no valid run leaves its answers blank) is drawn empty and says so; the
// other panels and the figure are still written.
TEST(Plot, APanelWithoutPointsIsDrawnEmptyAndTheFigureStillWritten)
{
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "no gnuplot";
  const auto dir = std::filesystem::temp_directory_path() / "rectify_test_plot";
  std::filesystem::remove_all(dir);
  ensure_directory(dir);
  write_file_atomic(dir / "d.csv", "x,y,blank\n1,2,\n2,3,nan\n3,1,\n");
  const PlotSeries filled{dir / "d.csv", "x", "y", "y", "linespoints"};
  const PlotSeries empty{dir / "d.csv", "x", "blank", "blank", "linespoints"};
  ASSERT_TRUE(render_plot(dir / "fig", {{"filled", "x", "y", false, false, {filled, empty}},
                                        {"empty", "x", "y", false, true, {empty}}}));
  EXPECT_TRUE(std::filesystem::exists(dir / "fig.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "fig.svg"));
  std::ifstream     in(dir / "fig.gp");
  const std::string script((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(script.find("no points to draw"), std::string::npos);
  EXPECT_EQ(script.find("using ($1*1):($3*1)"), std::string::npos) << script; // the blank column is not plotted
  EXPECT_NE(script.find("using ($1*1):($2*1)"), std::string::npos) << script;
  std::filesystem::remove_all(dir);
}

TEST(CaseFile, EachRealKeyIsReadReportedAndNamedFromItsOneTable)
{
  // a value for every real key of [fluid], [reed_material] and [solver]
  // (inside its range, not its default): read into the struct, reported in
  // to_json, reachable by [uncertain] exactly where the table says so
  std::string text;
  std::vector<std::tuple<std::string, std::string, double, bool>> given;
  const auto  table = [&](const std::string &name, const auto &keys, const auto &defaults) {
    text += "[" + name + "]\n";
    for (const auto &k : keys)
      {
        const double d = defaults.*k.field, v = d == 0.0 ? 0.01 : k.bounds.contains(1.01 * d) ? 1.01 * d : 0.99 * d;
        ASSERT_TRUE(k.bounds.contains(v)) << name << "." << k.key;
        text += std::string(k.key) + " = " + format_number(v) + "\n";
        given.emplace_back(name, k.key, std::stod(format_number(v)), k.uncertain);
      }
  };
  table("fluid", fluid_keys(), FluidParameters{});
  table("reed_material", material_keys(), ReedMaterial{});
  table("solver", system::solver_keys(), system::SolverParameters{});
  auto       p    = system::SystemParameters::from_case(parse(text));
  const auto json = p.to_json();
  for (const auto &[name, key, v, uncertain] : given)
    {
      EXPECT_EQ(json[name][key].get<double>(), v) << name << "." << key;
      double *field = p.real_field(name, key);
      EXPECT_EQ(field != nullptr, uncertain) << name << "." << key;
      if (field)
        EXPECT_EQ(*field, v) << name << "." << key;
    }
  EXPECT_EQ(json["solver"]["jacobian"], "analytic"); // the text keys beside them
  EXPECT_EQ(json["fluid"]["cavitation"], "discrete-cavity");
  // a value outside a table's range is refused with the key named
  expect_input_error([&] { (void)system::SystemParameters::from_case(parse("[solver]\nrelative_tolerance = 0.5\n")); },
                     {"[solver]", "relative_tolerance", "0.5"});
}
