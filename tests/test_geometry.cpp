// The valve's geometry as data (issue 19): the outline and ports read from a
// case, the plane geometry under them against exact values, and every check
// with the error it gives.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_helpers.h"
#include "common/case_edit.h"
#include "common/case_file.h"
#include "common/polygon.h"
#include "common/valve_geometry.h"
#include "mesher/parameters.h"

using namespace rectify;
using geometry::Polygon;

namespace
{
  ValveGeometry read(const std::string &text, const std::filesystem::path &dir = ".")
  {
    return ValveGeometry::from_case(CaseFile::parse(text, "test.toml", dir));
  }

  /// The error `text` gives, or "" if it reads.
  std::string error_of(const std::string &text, const std::filesystem::path &dir = ".")
  {
    try
      {
        const CaseFile f = CaseFile::parse(text, "test.toml", dir);
        (void)mesher::MeshParameters::from_case(f); // the geometry and the mesh's resolution
        f.check_all_keys_known();
        return "";
      }
    catch (const InputError &e)
      {
        return e.what();
      }
  }

  const std::string rectangle = "[geometry]\n"
                                "reed_outline_m = [[0.0, -2.54e-3], [6.1e-3, -2.54e-3], [6.1e-3, 2.54e-3], [0.0, 2.54e-3]]\n";
  const std::string one_port  = "[[port]]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 3.175e-3\n";

  std::filesystem::path cases_dir() { return std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases" / "geometries"; }
} // namespace

TEST(Geometry, TheOutlinePathDescribesTheReferenceValveAsTheShorthandDoes)
{
  const auto shorthand = ValveGeometry::from_case(CaseFile::load(std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases/reference.toml"));
  const auto outline   = ValveGeometry::from_case(CaseFile::load(cases_dir() / "rectangle-outline.toml"));
  EXPECT_TRUE(shorthand.is_shorthand());
  EXPECT_FALSE(outline.is_shorthand());
  EXPECT_EQ(shorthand.reed_boundary(), outline.reed_boundary());
  EXPECT_EQ(shorthand.clamp_line_y(), outline.clamp_line_y());
  ASSERT_EQ(outline.ports().size(), 1u);
  EXPECT_EQ(shorthand.ports()[0].center_m, outline.ports()[0].center_m);
  EXPECT_EQ(shorthand.ports()[0].diameter_m, outline.ports()[0].diameter_m);
  EXPECT_EQ(shorthand.ports()[0].length_m, outline.ports()[0].length_m);
  // The shorthand's fields as code written for the rectangle reads them.
  EXPECT_EQ(outline.reed_length_m, shorthand.reed_length_m);
  EXPECT_EQ(outline.reed_width_m, shorthand.reed_width_m);
  EXPECT_DOUBLE_EQ(outline.port_diameter_m, shorthand.port_diameter_m);
  EXPECT_EQ(outline.port_center_x_m, shorthand.port_center_x_m);
  // The shorthand's record is what it always was (a map set's hash).
  EXPECT_EQ(shorthand.to_json().size(), 10u);
  EXPECT_TRUE(outline.to_json().contains("reed_outline_m"));
}

TEST(Geometry, AClockwiseOutlineIsTheSameReed)
{
  const auto ccw = read(rectangle + one_port);
  const auto cw  = read("[geometry]\nreed_outline_m = [[0.0, 2.54e-3], [6.1e-3, 2.54e-3], [6.1e-3, -2.54e-3], [0.0, -2.54e-3]]\n"
                        "reed_fillet_radii_m = [0, 1e-3, 0.5e-3, 0]\n" + one_port);
  EXPECT_GT(geometry::signed_area(cw.reed_corners()), 0);
  EXPECT_NEAR(ccw.reed_area_m2(), 6.1e-3 * 5.08e-3, 1e-18);
  // The radii follow their corners: 1 mm at (6.1, 2.54) mm, 0.5 mm at (6.1, -2.54) mm.
  const auto corners = cw.reed_corners();
  const auto radii   = cw.fillet_radii();
  for (std::size_t i = 0; i < corners.size(); ++i)
    {
      if (corners[i][0] > 0 && corners[i][1] > 0)
        {
          EXPECT_EQ(radii[i], 1e-3);
        }
      if (corners[i][0] > 0 && corners[i][1] < 0)
        {
          EXPECT_EQ(radii[i], 0.5e-3);
        }
    }
}

TEST(Geometry, FilletsCirclesAndWidthsAgainstExactValues)
{
  // A rounded tip: each of the two corners loses r^2 less the polygonal
  // sector of 18 steps of 5 degrees, (18 / 2) r^2 sin(5 deg).
  const double r = 1.5e-3, L = 6.1e-3, W = 5.08e-3;
  const auto   g = read(rectangle + "reed_fillet_radius_m = 1.5e-3\n" + one_port);
  const double lost = r * r - 9 * r * r * std::sin(M_PI / 36);
  EXPECT_NEAR(g.reed_area_m2(), L * W - 2 * lost, 1e-12 * L * W);
  // The arcs' points lie on their circles, centred r inside both edges.
  for (const auto &p : g.reed_boundary())
    if (p[0] > L - r + 1e-12 && std::abs(p[1]) > W / 2 - r + 1e-12)
      {
        EXPECT_NEAR(std::hypot(p[0] - (L - r), std::abs(p[1]) - (W / 2 - r)), r, 1e-15);
      }
  // The clamp line's corners stay sharp with one radius for all.
  EXPECT_EQ(g.fillet_radii()[0], 0.0);
  EXPECT_EQ(g.fillet_radii()[3], 0.0);
  // A circle's polygon keeps its area.
  for (const std::size_t n : {6u, 16u, 96u})
    EXPECT_NEAR(geometry::signed_area(geometry::circle_polygon({1e-3, 2e-3}, 0.7e-3, n)), M_PI * 0.49e-6, 1e-20);
  // Widths: the slot (1.2 mm across), the neck (3 mm), the rectangle (5.08 mm).
  const auto slot = read(rectangle + "[[port]]\noutline_csv = \"slot.csv\"\n", cases_dir());
  // (The slot's ends are 12 chords of a semicircle, each up to its
  // sagitta r (1 - cos 7.5 deg) = 5.1 um inside the arc: the width between
  // chords of the two ends' flanks is short of 1.2 mm by at most two.)
  const double sagitta = 0.6e-3 * (1 - std::cos(M_PI / 24));
  EXPECT_LE(geometry::narrowest_width(slot.ports()[0].outline_m), 1.2e-3 + 1e-12);
  EXPECT_GE(geometry::narrowest_width(slot.ports()[0].outline_m), 1.2e-3 - 2 * sagitta);
  const auto necked = ValveGeometry::from_case(CaseFile::load(cases_dir() / "necked.toml"));
  EXPECT_NEAR(geometry::narrowest_width(necked.reed_corners()), 3.0e-3, 1e-12);
  EXPECT_NEAR(geometry::narrowest_width(g.reed_corners()), W, 1e-12);
  // Fillets that turn either way: a convex corner's arc takes away, a
  // concave one's (the neck) adds, r^2 tan(phi / 2) less the polygonal
  // sector (n / 2) r^2 sin(phi / n), phi the turn, n its 5-degree steps.
  {
    const auto   corners = necked.reed_corners();
    const auto   radii   = necked.fillet_radii();
    const auto   angles  = geometry::interior_angles(corners);
    double       area    = geometry::signed_area(corners);
    for (std::size_t i = 0; i < corners.size(); ++i)
      if (radii[i] > 0)
        {
          const double phi = std::abs(M_PI - angles[i]);
          const double n   = std::ceil(phi / (M_PI / 36) - 1e-9);
          const double a   = radii[i] * radii[i] * (std::tan(phi / 2) - 0.5 * n * std::sin(phi / n));
          area += angles[i] < M_PI ? -a : a;
        }
    EXPECT_NEAR(necked.reed_area_m2(), area, 1e-12 * area);
  }
  // The seat land of the reference port, and of the tapered reed's (its side
  // edge at distance (2.54 - 0.79 x / 6.1) cos(atan(0.79 / 6.1)) from the axis).
  EXPECT_NEAR(read(rectangle + one_port).seat_land_m(), 2.54e-3 - 3.175e-3 / 2, 1e-15);
  const auto   tapered = ValveGeometry::from_case(CaseFile::load(cases_dir() / "tapered.toml"));
  const double slope   = 0.79e-3 / 6.1e-3;
  EXPECT_NEAR(tapered.seat_land_m(), (2.54e-3 - slope * 3.3e-3) * std::cos(std::atan(slope)) - 3.175e-3 / 2, 1e-15);
}

TEST(Geometry, EveryExampleIsValidAndDrawn)
{
  nlohmann::json rectangle_summary;
  for (const char *name : {"rectangle-outline", "rounded-tip", "tapered", "necked", "two-ports", "slotted-port"})
    {
      SCOPED_TRACE(name);
      const auto out = test_support::scratch(std::string("geometry-") + name);
      const auto run = test_support::rectify_cli("geometry --case " + (cases_dir() / (std::string(name) + ".toml")).string() +
                                                 " --out " + out.string());
      ASSERT_EQ(run.exit_code, 0) << run.output;
      // ... and reads as every stage reads it
      const auto check = test_support::rectify_cli("check --case " + (cases_dir() / (std::string(name) + ".toml")).string() +
                                                   " --out " + (out / "check").string());
      EXPECT_EQ(check.exit_code, 0) << check.output;
      std::ifstream   in(out / "summary.json");
      nlohmann::json  s = nlohmann::json::parse(in);
      if (std::string(name) == "rectangle-outline")
        rectangle_summary = s;
      const ValveGeometry g = ValveGeometry::from_case(CaseFile::load(cases_dir() / (std::string(name) + ".toml")));
      EXPECT_EQ(s["ports"].size(), g.ports().size());
      EXPECT_DOUBLE_EQ(s["reed_area_m2"].get<double>(), g.reed_area_m2());
      EXPECT_TRUE(std::filesystem::exists(out / "reed.csv"));
      EXPECT_TRUE(std::filesystem::exists(out / "port-1.csv"));
      if (std::system("command -v gnuplot > /dev/null 2>&1") == 0)
        {
          EXPECT_TRUE(std::filesystem::exists(out / "geometry.png"));
        }
    }
  // The summary's numbers for the rectangle drawn as an outline and the slot.
  {
    const nlohmann::json &s = rectangle_summary;
    EXPECT_NEAR(s["reed_perimeter_m"].get<double>(), 2 * (6.1e-3 + 5.08e-3), 1e-15);
    EXPECT_NEAR(s["reed_centroid_m"][0].get<double>(), 3.05e-3, 1e-15);
    EXPECT_NEAR(s["reed_centroid_m"][1].get<double>(), 0.0, 1e-15);
    EXPECT_NEAR(s["ports"][0]["hydraulic_diameter_m"].get<double>(), 3.175e-3, 1e-15); // a circle's is its diameter
    double previous = 0;
    for (const auto &f : s["features_smallest_first"])
      {
        EXPECT_GE(f["size_m"].get<double>(), previous);
        previous = f["size_m"].get<double>();
      }
    EXPECT_NEAR(s["features_smallest_first"][0]["size_m"].get<double>(), 2.54e-3 - 3.175e-3 / 2, 1e-15); // the land
  }
  {
    // the slot is symmetric about (3.3, 0) mm: its centroid
    const auto slot = ValveGeometry::from_case(CaseFile::load(cases_dir() / "slotted-port.toml")).ports()[0];
    EXPECT_NEAR(slot.centroid_m()[0], 3.3e-3, 1e-12);
    EXPECT_NEAR(slot.centroid_m()[1], 0.0, 1e-12);
  }
  const auto two = ValveGeometry::from_case(CaseFile::load(cases_dir() / "two-ports.toml"));
  EXPECT_EQ(two.ports().size(), 2u);
  EXPECT_NEAR(two.ports_area_m2(), 2 * M_PI * 1e-6, 1e-18);
}

TEST(Geometry, EveryCheckNamesWhatIsWrong)
{
  struct Case
  {
    std::string text, expected;
  };
  const std::string bowtie = "[geometry]\nreed_outline_m = [[0.0, -2.54e-3], [6.1e-3, 2.54e-3], [6.1e-3, -2.54e-3], [0.0, 2.54e-3]]\n";
  const std::vector<Case> cases = {
    {bowtie + one_port, "not simple"},
    {rectangle + "clamp_line_m = [[0.0, -2.0e-3], [0.0, 2.54e-3]]\n" + one_port, "[geometry] clamp_line_m"},
    {rectangle + "clamp_line_m = [[1e-3, -2.54e-3], [1e-3, 2.54e-3]]\n" + one_port, "two different points on x = 0"},
    {"[geometry]\nreed_outline_m = [[0.5e-3, -2.54e-3], [6.1e-3, -2.54e-3], [6.1e-3, 2.54e-3], [0.5e-3, 2.54e-3]]\n" + one_port,
     "0 corner(s) on x = 0"},
    {"[geometry]\nreed_outline_m = [[0.0, -2.54e-3], [6.1e-3, -2.54e-3], [6.1e-3, 2.54e-3], [0.0, 2.54e-3], [-1e-3, 0.0]]\n" + one_port,
     "the reed lies in x >= 0"},
    {rectangle + "[[port]]\ncenter_m = [5.5e-3, 0.0]\ndiameter_m = 3.175e-3\n", "the reed does not cover port 1"},
    {rectangle + "[[port]]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 4.8e-3\n", "seat land of 0.14 mm, less than seat_land_min_m"},
    {rectangle + one_port + "[[port]]\ncenter_m = [4.0e-3, 0.5e-3]\ndiameter_m = 1.0e-3\n", "port 2 overlaps port 1"},
    {rectangle + "[[port]]\ncenter_m = [2.0e-3, 0.0]\ndiameter_m = 1.5e-3\n[[port]]\ncenter_m = [3.65e-3, 0.0]\ndiameter_m = 1.5e-3\n",
     "port 2 is 0.15 mm from port 1, less than seat_land_min_m"},
    {rectangle + "reed_fillet_radius_m = 3e-3\n" + one_port, "the fillets of corners 2 and 3"},
    {rectangle + "reed_fillet_radii_m = [0.5e-3, 0, 0, 0]\n" + one_port, "must be sharp"},
    {rectangle + "reed_fillet_radii_m = [0, 0, 0]\n" + one_port, "3 radii for an outline of 4 corners"},
    {rectangle + "reed_length_m = 6e-3\n" + one_port, "not both"},
    {"[geometry]\nport_diameter_m = 3e-3\n" + one_port, "not both"},
    {"[geometry]\nreed_fillet_radius_m = 1e-3\n", "applies to a reed given as its outline"},
    {rectangle + "[[port]]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 3e-3\noutline_m = [[3e-3, 0], [4e-3, 0], [3.5e-3, 1e-3]]\n", "not both"},
    {rectangle + "[[port]]\ncenter_m = [3.3e-3, 0.0]\n", "[[port]] #1 diameter_m: missing"},
    {rectangle + "[[port]]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 3e-3\ndiameter_mm = 3\n", "[[port]] #1 diameter_mm"},
    {rectangle + "[port]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 3e-3\n", "must be written [[port]]"},
    {"[geometry]\nreed_outline_m = [[0.0, -2.54e-3], [9.5e-3, -2.54e-3], [9.5e-3, 2.54e-3], [0.0, 2.54e-3]]\n" + one_port,
     "outside the pocket's floor"},
    {"[geometry]\nreed_outline_m = [[0.0, -2.54e-3], [6.1e-3, nan], [6.1e-3, 2.54e-3], [0.0, 2.54e-3]]\n" + one_port,
     "point 2 = [0.0061, nan]"},
    {"[geometry]\nreed_outline_m = [[0.0, -2.54e-3], [6.1e-3], [6.1e-3, 2.54e-3], [0.0, 2.54e-3]]\n" + one_port,
     "point 2: expected [x, y]"},
    {rectangle + "[[port]]\noutline_m = [[3e-3, -1e-3], [4e-3, 1e-3], [4e-3, -1e-3], [3e-3, 1e-3]]\n", "[[port]] #1 outline_m: the outline is not simple"},
    {rectangle + "[[port]]\noutline_csv = \"missing.csv\"\n", "[[port]] #1 outline_csv = 'missing.csv'"},
    // A feature the mesh cannot resolve: a 0.25 mm seat land under cells of 0.3 mm.
    {rectangle + "seat_land_min_m = 0.1e-3\n[[port]]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 4.58e-3\n",
     "[mesh] size_reed_m = 3e-04: coarser than the seat land around port 1"},
  };
  for (const auto &c : cases)
    {
      SCOPED_TRACE(c.text);
      const std::string error = error_of(c.text);
      EXPECT_NE(error.find(c.expected), std::string::npos) << error;
    }
  // A CSV outline with a column missing names the file.
  const auto dir = test_support::scratch("geometry-csv");
  {
    std::ofstream csv(dir / "port.csv");
    csv << "x_m,z_m\n3e-3,0\n4e-3,0\n3.5e-3,1e-3\n";
  }
  const std::string error = error_of(rectangle + "[[port]]\noutline_csv = \"port.csv\"\n", dir);
  EXPECT_NE(error.find("port.csv"), std::string::npos) << error;
  EXPECT_NE(error.find("y_m"), std::string::npos) << error;
  // And the shorthand keeps its messages.
  EXPECT_NE(error_of("[geometry]\nport_center_x_m = 5.5e-3\n").find("does not cover its port"), std::string::npos);
}

TEST(Geometry, ABadGeometryWritesNothing)
{
  const auto dir = test_support::scratch("geometry-bad");
  {
    std::ofstream bad(dir / "bad.toml");
    bad << "[geometry]\nreed_outline_m = [[0.0, -2.54e-3], [6.1e-3, 2.54e-3], [6.1e-3, -2.54e-3], [0.0, 2.54e-3]]\n";
  }
  const auto out = dir / "out";
  const auto run = test_support::rectify_cli("geometry --case " + (dir / "bad.toml").string() + " --out " + out.string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("not simple"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out / "summary.json"));
  EXPECT_FALSE(std::filesystem::exists(out / "reed.csv"));
}

// A resumed map of another outline is refused: two outlines with the same
// bounding box and first port (a reed tapering towards its tip, and the same
// taper reversed) are different reeds, and map-stiffness's checkpoint says so.
TEST(Geometry, AMapOfAnotherOutlineIsNotResumed)
{
  const auto dir = test_support::scratch("geometry-resume");
  const auto write = [&](const std::string &name, const std::string &outline) {
    std::ofstream f(dir / name);
    f << "[geometry]\nreed_outline_m = " << outline << "\n[[port]]\ncenter_m = [3.3e-3, 0.0]\ndiameter_m = 3.175e-3\n"
      << "[valves]\nresistance_map = \"" << (std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases/thesis-resistance.csv").string()
      << "\"\n[stiffness]\ncells_along_length = 12\ncells_across_width = 10\nn_modes = 1\n";
  };
  write("narrowing.toml", "[[0.0, -2.54e-3], [6.1e-3, -1.75e-3], [6.1e-3, 1.75e-3], [0.0, 2.54e-3]]");
  write("widening.toml", "[[0.0, -1.75e-3], [6.1e-3, -2.54e-3], [6.1e-3, 2.54e-3], [0.0, 1.75e-3]]");
  const auto out   = dir / "map";
  const auto first = test_support::rectify_cli("map-stiffness --case " + (dir / "narrowing.toml").string() +
                                               " --thickness 0.1e-3:0.12e-3:2 --out " + out.string());
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const auto second = test_support::rectify_cli("map-stiffness --case " + (dir / "widening.toml").string() +
                                                " --thickness 0.1e-3:0.12e-3:2 --out " + out.string());
  EXPECT_NE(second.exit_code, 0) << second.output;
}

// A what-if edits a case's text (common/case_edit.h): on an outline case a
// [geometry] key goes into [geometry], not into the [[port]] table after it
// (which refused the edited case: "unknown key"), and the outlines' CSV
// files are found from wherever the edited case is read.
TEST(Geometry, AnEditedOutlineCaseKeepsItsPortsAndItsFiles)
{
  for (const char *name : {"two-ports", "slotted-port"})
    {
      std::ifstream     in(cases_dir() / (std::string(name) + ".toml"));
      std::stringstream text;
      text << in.rdbuf();
      const std::string edited = edit_case_text(text.str(), cases_dir(),
                                                {{"geometry", "reed_thickness_m", "0.2e-3", "what-if"},
                                                 {"mesh", "size_reed_m", "0.25e-3", "what-if"}});
      const CaseFile f  = CaseFile::parse(edited, "edited.toml", "/"); // read from elsewhere
      const auto     mp = mesher::MeshParameters::from_case(f);
      EXPECT_EQ(mp.geometry.reed_thickness_m, 0.2e-3) << name;
      EXPECT_EQ(mp.settings.size_reed_m, 0.25e-3) << name;
      const auto original = ValveGeometry::from_case(CaseFile::load(cases_dir() / (std::string(name) + ".toml")));
      ASSERT_EQ(mp.geometry.ports().size(), original.ports().size()) << name;
      for (std::size_t k = 0; k < original.ports().size(); ++k)
        EXPECT_EQ(mp.geometry.ports()[k].polygon(64), original.ports()[k].polygon(64)) << name << " port " << k;
    }
}
