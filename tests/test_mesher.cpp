// The mesher (mesher/): volumes and areas against the geometry's analytic
// values, boundary ids, conformity, quality over the openings, dimension
// changes, the reed shape, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "common/case_file.h"
#include "common/io.h"
#include "mesher/bulk_tetgen.h"
#include "mesher/mesher.h"
#include "mesher/parameters.h"
#include "mesher/writers.h"
#include "tests/cli_helpers.h"

using namespace rectify;
using namespace rectify::mesher;
using namespace rectify::test_support;

namespace
{
  MeshParameters reference() { return MeshParameters::from_case(CaseFile::load(reference_case_path())); }

  /// Boundary faces recomputed from the cells alone: faces of exactly one cell.
  std::map<std::array<std::uint32_t, 3>, int> faces_of_one_cell(const TetMesh &m)
  {
    std::map<std::array<std::uint32_t, 3>, int> count;
    for (const auto &c : m.cells)
      for (int k = 0; k < 4; ++k)
        {
          std::array<std::uint32_t, 3> f;
          int                          n = 0;
          for (int j = 0; j < 4; ++j)
            if (j != k)
              f[n++] = c[j];
          std::sort(f.begin(), f.end());
          ++count[f];
        }
    std::erase_if(count, [](const auto &kv) { return kv.second != 1; });
    return count;
  }
} // namespace

// The analytic fluid volume: pocket + port - reed - the closed part of the gap.
TEST(Mesher, VolumeEqualsTheAnalyticFluidVolume)
{
  const auto p = reference();
  for (double opening : {2e-6, 10e-6, 100e-6, 1210e-6})
    {
      const auto  r = mesh_valve(p, opening);
      const auto &i = r.info;
      EXPECT_NEAR(i.fluid_volume_m3 / i.exact_fluid_volume_m3, 1.0, 1e-6) << opening;
      // the layered gap reproduces the sampled reed exactly
      EXPECT_NEAR(i.gap_volume_m3 / i.exact_gap_volume_m3, 1.0, 1e-9) << opening;
      // an independent volume: the closed boundary surface (CGAL)
      EXPECT_TRUE(i.surface.closed && i.surface.outward && !i.surface.self_intersecting) << opening;
      EXPECT_NEAR(i.surface.volume_m3 / i.fluid_volume_m3, 1.0, 1e-9) << opening;
      EXPECT_EQ(i.gap_layers, p.settings.gap_layers);
      // the gap is open from the cut-off on, and its thinnest part has
      // gap_layers layers: check the cells under the reed at the cut-off station
      EXPECT_NEAR(i.cutoff_thickness_m, opening * p.settings.gap_cutoff_ratio, 0.3 * opening * p.settings.gap_cutoff_ratio);
    }
}

// Up to the stop: near the ceiling the slab's margin shrinks to half the
// room above the reed's tip; the mesh keeps its exact volume and closed
// surface there, the slab's top stays under the ceiling by as much again,
// and one step beyond the reach is refused naming the key.
TEST(Mesher, ReachesTheStopWithTheSlabsMarginShrunkUnderTheCeiling)
{
  const auto   p     = reference();
  const double reach = p.geometry.pocket_height_m - p.geometry.reed_thickness_m - 2 * p.settings.min_slab_margin_m;
  EXPECT_NEAR(p.max_opening_m(), reach, 1e-15);
  EXPECT_NEAR(reach, 1.853e-3, 1e-12); // 2.0 - 0.127 - 2 x 0.010 mm
  for (double opening : {1.5e-3, 1.8e-3, reach})
    {
      const auto  r = mesh_valve(p, opening);
      const auto &i = r.info;
      const double room = p.geometry.pocket_height_m - p.geometry.reed_thickness_m - opening;
      EXPECT_NEAR(i.slab_margin_m, std::min(p.settings.slab_margin_m, room / 2), 1e-15) << opening;
      EXPECT_GE(i.slab_margin_m, p.settings.min_slab_margin_m * (1 - 1e-9)) << opening;
      EXPECT_NEAR(i.fluid_volume_m3 / i.exact_fluid_volume_m3, 1.0, 1e-6) << opening;
      EXPECT_TRUE(i.surface.closed && i.surface.outward && !i.surface.self_intersecting) << opening;
      EXPECT_GT(i.quality.all.min_dihedral_deg, 0.1) << opening;
    }
  try
    {
      (void)mesh_valve(p, reach + 2e-6);
      ADD_FAILURE() << "meshed beyond the reach";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("min_slab_margin_m"), std::string::npos) << e.what();
    }
}

// By hand: the reference pocket, port, reed; independent of the mesher's formulas.
TEST(Mesher, ExactVolumeIsTheReferenceGeometrysVolume)
{
  const auto   p       = reference();
  const double opening = 1e-6; // closed part negligible: W * opening * int phi < 1e-13 m^3
  const auto   r       = mesh_valve(p, opening);
  const double by_hand = 9e-3 * 8e-3 * 2e-3 + M_PI * std::pow(3.175e-3 / 2, 2) * 3e-3 -
                         6.1e-3 * 5.08e-3 * 0.127e-3;
  EXPECT_NEAR(r.info.exact_fluid_volume_m3 / by_hand, 1.0, 1e-6);
  EXPECT_NEAR(r.info.fluid_volume_m3 / by_hand, 1.0, 1e-6);
}

TEST(Mesher, EveryBoundaryFaceHasOneIdAndInletOutletAreasMatch)
{
  const auto p = reference();
  for (double opening : {2e-6, 300e-6})
    {
      const auto  r = mesh_valve(p, opening);
      const auto &m = r.mesh;
      auto        expected = faces_of_one_cell(m);
      ASSERT_EQ(expected.size(), m.boundary.size()) << opening;
      for (const auto &f : m.boundary)
        {
          auto key = f.vertices;
          std::sort(key.begin(), key.end());
          EXPECT_EQ(expected.erase(key), 1u) << "a boundary face listed twice or not a boundary face";
          EXPECT_TRUE(f.id >= inlet && f.id <= reed) << int(f.id);
        }
      const auto &i = r.info;
      EXPECT_NEAR(i.boundary_area_m2[inlet] / (M_PI * std::pow(0.5 * 3.175e-3, 2)), 1.0, 1e-6);
      EXPECT_NEAR(i.boundary_area_m2[outlet] / (8e-3 * 2e-3), 1.0, 1e-6);
      for (int id = inlet; id <= reed; ++id)
        EXPECT_GT(i.boundary_faces[id], 0u) << id;
      // Inlet faces lie on z = -3 mm, outlet faces on x = 9 mm; reed faces
      // within the reed's box, walls never on the inlet or outlet planes.
      for (const auto &f : m.boundary)
        for (auto v : f.vertices)
          {
            const auto &x = m.vertices[v];
            if (f.id == inlet)
              {
                EXPECT_NEAR(x[2], -3e-3, 1e-15);
              }
            if (f.id == outlet)
              {
                EXPECT_NEAR(x[0], 9e-3, 1e-15);
              }
            if (f.id == reed)
              {
                EXPECT_LE(x[0], 6.1e-3 + 1e-15);
                EXPECT_LE(std::abs(x[1]), 2.54e-3 + 1e-15);
                EXPECT_LE(x[2], opening + 0.127e-3 + 1e-12);
              }
          }
      // Divergence theorem with the ids' faces: sum of (x . n) dA / 3 = volume.
      double flux = 0;
      for (const auto &f : m.boundary)
        {
          const auto &a = m.vertices[f.vertices[0]], &b = m.vertices[f.vertices[1]],
                     &c = m.vertices[f.vertices[2]];
          flux += signed_volume({0, 0, 0}, a, b, c);
        }
      EXPECT_NEAR(flux / i.fluid_volume_m3, 1.0, 1e-9);
    }
}

// Quality over a sweep of openings: no inverted cell; TetGen's cells
// isotropic; every layered cell exactly a third of a vertical prism over a
// good floor triangle, no thinner than the thinnest layer the layering
// prescribes (so no sliver: its flatness is the layer's, nothing more).
TEST(Mesher, QualityBoundsHoldOverTheOpenings)
{
  const auto  p = reference();
  const auto &s = p.settings;
  for (double opening : {2e-6, 5e-6, 20e-6, 60e-6, 200e-6, 600e-6, 1210e-6})
    {
      const auto  r = mesh_valve(p, opening);
      const auto &m = r.mesh;
      const auto &q = r.info.quality;
      EXPECT_GE(q.region[bulk].min_dihedral_deg, 4.0) << opening;
      EXPECT_LE(q.region[bulk].max_aspect_ratio, 15.0) << opening;
      // 13.3 deg at the default 0.25 mm station spacing (16.8 at 0.1 mm): the
      // station lines next to the port's polygon; CGAL asks for 25 elsewhere
      EXPECT_GE(q.min_floor_angle_deg, 12.0) << opening;
      const double h_cut = r.info.cutoff_thickness_m, t = p.geometry.reed_thickness_m;
      const double thinnest =
        std::min({h_cut / s.gap_layers, (t - h_cut) / s.reed_layers, s.slab_margin_m / s.above_layers,
                  (t + s.slab_margin_m) / (s.gap_layers + s.reed_layers + s.above_layers),
                  p.geometry.port_length_m / std::ceil(p.geometry.port_length_m / s.port_layer_m)});
      std::size_t n_layered = 0;
      for (std::size_t c = 0; c < m.cells.size(); ++c)
        {
          const double volume = cell_volume(m, c);
          ASSERT_GT(volume, 0.0) << "inverted cell " << c << " at " << opening;
          if (m.region[c] == bulk)
            continue;
          ++n_layered;
          // the vertical edge and the floor triangle under the cell
          const auto &v = m.cells[c];
          int         a = -1, b = -1;
          for (int i = 0; i < 4; ++i)
            for (int j = i + 1; j < 4; ++j)
              if (m.vertices[v[i]][0] == m.vertices[v[j]][0] && m.vertices[v[i]][1] == m.vertices[v[j]][1])
                a = i, b = j;
          ASSERT_GE(a, 0) << "a layered cell without a vertical edge";
          std::vector<std::array<double, 2>> base;
          for (int i = 0; i < 4; ++i)
            if (i != b)
              base.push_back({m.vertices[v[i]][0], m.vertices[v[i]][1]});
          const double ux = base[1][0] - base[0][0], uy = base[1][1] - base[0][1];
          const double wx = base[2][0] - base[0][0], wy = base[2][1] - base[0][1];
          const double area = 0.5 * std::abs(ux * wy - uy * wx);
          const double dz   = std::abs(m.vertices[v[a]][2] - m.vertices[v[b]][2]);
          ASSERT_NEAR(volume / (area * dz / 3), 1.0, 1e-9) << "not a third of a vertical prism";
          ASSERT_GE(dz, thinnest * (1 - 1e-9)) << "a layer thinner than prescribed at " << opening;
        }
      EXPECT_GT(n_layered, 0u);
    }
}

TEST(Mesher, ChangingADimensionChangesTheVolumeAsTheGeometrySays)
{
  const double opening = 50e-6;
  const auto   base    = reference();
  const auto   v0      = mesh_valve(base, opening).info.fluid_volume_m3;

  auto thick                        = base;
  thick.geometry.reed_thickness_m   = 0.2e-3;
  const auto v1                     = mesh_valve(thick, opening).info.fluid_volume_m3;
  EXPECT_NEAR((v1 - v0) / (-6.1e-3 * 5.08e-3 * (0.2e-3 - 0.127e-3)), 1.0, 1e-6);

  auto narrow                       = base;
  narrow.geometry.port_diameter_m   = 2.5e-3;
  const auto v2                     = mesh_valve(narrow, opening).info.fluid_volume_m3;
  EXPECT_NEAR((v2 - v0) / (M_PI * (std::pow(1.25e-3, 2) - std::pow(1.5875e-3, 2)) * 3e-3), 1.0, 1e-5);
}

TEST(Mesher, OutletFaceIsACaseParameter)
{
  for (const auto &[face, area] : {std::pair{"ceiling", 9e-3 * 8e-3}, std::pair{"y-min", 9e-3 * 2e-3},
                                   std::pair{"y-max", 9e-3 * 2e-3}})
    {
      auto p                 = reference();
      p.geometry.outlet_face = face;
      const auto r           = mesh_valve(p, 50e-6);
      EXPECT_NEAR(r.info.boundary_area_m2[outlet] / area, 1.0, 1e-9) << face;
      EXPECT_NEAR(r.info.exact_outlet_area_m2 / area, 1.0, 1e-15) << face;
    }
}

TEST(Mesher, ReedShapes)
{
  const auto beam = ReedShape::beam(6.1e-3, 3.3e-3);
  EXPECT_DOUBLE_EQ(beam(0), 0);
  EXPECT_NEAR(beam(6.1e-3), 1.0, 1e-15);
  EXPECT_NEAR(beam(3.3e-3 - 1e-12), beam(3.3e-3 + 1e-12), 1e-9); // continuous at the load
  // sampled integral -> the beam's exact integral (Simpson on the two polynomials)
  const double a = 3.3e-3, L = 6.1e-3;
  const double exact = (a * a * a * a - a * a * a * a / 4) / (a * a * (3 * L - a)) +
                       (1.5 * (L * L - a * a) - a * (L - a)) / (3 * L - a);
  double previous_error = 1;
  for (double spacing : {0.4e-3, 0.2e-3, 0.1e-3})
    {
      const SampledShape s(beam, spacing);
      const double       error = std::abs(s.integral_to_station(s.stations().size() - 1) - exact) / exact;
      EXPECT_LT(error, previous_error / 3.5) << spacing; // second order
      previous_error = error;
      EXPECT_LT(s.max_sampling_error(), 0.2 * spacing * spacing / (1e-3 * 1e-3));
    }
  // a table is scaled to phi(L) = 1
  const auto table = ReedShape::table({0, 3e-3, 6.1e-3}, {0, 0.5e-6, 2e-6}, 6.1e-3, "t.csv");
  EXPECT_DOUBLE_EQ(table(6.1e-3), 1.0);
  EXPECT_DOUBLE_EQ(table(3e-3), 0.25);
}

// The seat film's modal area, the reed's shape integrated over its footprint
// less the port: for a rigid reed (phi = 1) it is the footprint's area less
// the port's, L W - pi r^2; for the beam shape the footprint's part is
// W (a^2 / (4 (3L - a)) 3 + (3L^2/2 - a L - a^2/2) / (3L - a)) (the
// cantilever's phi integrated in closed form) and the port's part is summed
// here on a fine polar grid of the port's disc (midpoint, 1e6 cells).
TEST(Mesher, SeatFilmModalArea)
{
  ValveGeometry g;
  const double  L = g.reed_length_m, W = g.reed_width_m, a = g.port_center_x_m, r = 0.5 * g.port_diameter_m;
  EXPECT_NEAR(mesher::seat_film_modal_area_m2(g, [](double) { return 1.0; }), L * W - M_PI * r * r,
              1e-7 * L * W);
  const auto beam = mesher::ReedShape::beam(L, a);
  const double footprint =
    W * (0.75 * a * a / (3 * L - a) + (1.5 * L * L - a * L - 0.5 * a * a) / (3 * L - a));
  double    port = 0; // polar midpoint rule about the port's centre
  const int n    = 1000;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      {
        const double rho = (i + 0.5) * r / n, theta = (j + 0.5) * 2 * M_PI / n;
        port += beam(a + rho * std::cos(theta)) * rho * (r / n) * (2 * M_PI / n);
      }
  const double area = mesher::seat_film_modal_area_m2(g, [&](double s) { return beam(s); });
  std::printf("seat film modal area, beam shape: %.6g mm^2 (footprint %.6g, port %.6g)\n", area * 1e6,
              footprint * 1e6, port * 1e6);
  EXPECT_NEAR(area, footprint - port, 1e-6 * footprint);
}

TEST(Mesher, MeshesTheStiffnessSolversShapeTable)
{
  const auto dir = scratch("mesher_shape");
  std::string csv = "# a shape.csv as rectify stiffness writes it\ns_m,phi,phi_centerline\n";
  for (int k = 0; k <= 60; ++k)
    {
      const double s = 6.1e-3 * k / 60;
      csv += std::to_string(s) + "," + std::to_string(std::pow(s / 6.1e-3, 1.8)) + ",0\n";
    }
  write_file_atomic(dir / "shape.csv", csv);
  write_file_atomic(dir / "case.toml", "[mesh]\nshape = \"table\"\nshape_table = \"shape.csv\"\n");
  const auto p = MeshParameters::from_case(CaseFile::load(dir / "case.toml"));
  const auto r = mesh_valve(p, 30e-6);
  EXPECT_EQ(r.info.shape, "table");
  EXPECT_NEAR(r.info.fluid_volume_m3 / r.info.exact_fluid_volume_m3, 1.0, 1e-9);
  // the open gap's volume is W * opening * int phi from the cut-off to L:
  // phi = (s/L)^1.8 integrates to L (1 - u^2.8) / 2.8, u = cut-off / L
  // (the table's linear interpolation of 61 points aside)
  const double u = r.info.closed_to_m / 6.1e-3;
  EXPECT_NEAR(r.info.gap_volume_m3 / (5.08e-3 * 30e-6 * 6.1e-3 * (1 - std::pow(u, 2.8)) / 2.8), 1.0, 2e-3);
}

TEST(Mesher, BadInputNamesTheKeyBeforeMeshing)
{
  auto expect_error = [](const std::string &text, const std::string &fragment) {
    try
      {
        MeshParameters::from_case(CaseFile::parse(text, "m.toml"));
        ADD_FAILURE() << "accepted: " << text;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      }
  };
  expect_error("[geometry]\nport_center_x_m = 5.5e-3\n", "does not cover its port");
  expect_error("[geometry]\nport_center_x_m = 8.5e-3\nreed_length_m = 8.9e-3\n", "outside the seat");
  expect_error("[geometry]\npocket_width_m = 3e-3\n", "outside the seat");
  expect_error("[geometry]\npocket_width_m = 4e-3\n", "the reed must fit inside the pocket");
  expect_error("[geometry]\nreed_length_m = 9.5e-3\n", "reed_length_m");
  expect_error("[geometry]\npocket_height_m = 0\n", "[geometry] pocket_height_m");
  expect_error("[geometry]\nport_length_m = -3e-3\n", "[geometry] port_length_m");
  expect_error("[geometry]\noutlet_face = \"floor\"\n", "outlet_face");
  expect_error("[mesh]\nsize_reed_m = -1e-4\n", "[mesh] size_reed_m");
  expect_error("[mesh]\nsize_reed_m = 0.9e-3\nsize_far_m = 1e-3\n", "too coarse");
  expect_error("[mesh]\ngap_layers = 0\n", "[mesh] gap_layers");
  expect_error("[mesh]\ngap_cutoff_ratio = 0\n", "[mesh] gap_cutoff_ratio");
  expect_error("[mesh]\nshape = \"table\"\n", "shape_table");
  expect_error("[mesh]\nshape = \"parabola\"\n", "[mesh] shape");
  expect_error("[mesh]\nmin_slab_margin_m = 0.2e-3\n", "[mesh] min_slab_margin_m");

  const auto dir = scratch("mesher_bad_table");
  auto table_error = [&](const std::string &csv, const std::string &fragment) {
    write_file_atomic(dir / "shape.csv", csv);
    try
      {
        (void)ReedShape::from_csv(dir / "shape.csv", 6.1e-3);
        ADD_FAILURE() << "accepted: " << csv;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("shape.csv"), std::string::npos) << e.what();
      }
  };
  table_error("s_m,phi\n0,0\n0.003,0.6\n0.0045,0.5\n0.0061,1\n", "not monotone");
  table_error("s_m,phi\n0,0\n0.003,0.5\n0.005,1\n", "end at the reed's tip");
  table_error("s_m,phi\n0.001,0\n0.0061,1\n", "start at the clamp");
  table_error("s_m,phi\n0,0.1\n0.0061,1\n", "zero at the clamp");
  table_error("s_m,phi\n0,0\n0.003,0.5\n0.003,0.6\n0.0061,1\n", "increase strictly");
  table_error("s_m,phi\n0,0\n0.003,nan\n0.0061,1\n", "shape.csv");
  table_error("s,phi\n0,0\n0.0061,1\n", "s_m");

  const auto p = reference();
  EXPECT_THROW(mesh_valve(p, 1.9e-3), InputError); // through the ceiling
  EXPECT_THROW(mesh_valve(p, 0.0), InputError);
  EXPECT_THROW(mesh_valve(p, std::nan("")), InputError);
  EXPECT_THROW(parse_length("12 parsecs", "--opening"), InputError);
  EXPECT_DOUBLE_EQ(parse_length("100um", "x"), 100e-6);
  EXPECT_DOUBLE_EQ(parse_length("1.21mm", "x"), 1.21e-3);
  EXPECT_DOUBLE_EQ(parse_length("2e-6", "x"), 2e-6);
}

TEST(Mesher, TetgenFailureIsReportedWithItsCause)
{
  auto expect_failure = [](const std::vector<Point3>                        &points,
                           const std::vector<std::array<std::uint32_t, 3>> &triangles,
                           const std::string                                &cause) {
    try
      {
        (void)tetrahedralize_closed_surface(points, triangles, {});
        ADD_FAILURE() << "TetGen's input accepted";
      }
    catch (const MeshError &e)
      {
        EXPECT_NE(std::string(e.what()).find("TetGen"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(cause), std::string::npos) << e.what();
      }
  };
  // Two triangles crossing each other, not a closed surface.
  expect_failure({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, -1}, {0.2, 0.2, 1}, {1, 1, 1}},
                 {{0, 1, 2}, {3, 4, 5}}, "not a closed");
  // Two closed tetrahedra that interpenetrate.
  const std::vector<std::array<std::uint32_t, 3>> tet{{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}};
  auto two = tet;
  for (auto f : tet)
    two.push_back({f[0] + 4, f[1] + 4, f[2] + 4});
  expect_failure({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1},
                  {0.2, 0.2, 0.2}, {1.2, 0.2, 0.2}, {0.2, 1.2, 0.2}, {0.2, 0.2, 1.2}},
                 two, "intersects itself");
  // A closed surface TetGen meshes: the unit tetrahedron.
  const auto ok = tetrahedralize_closed_surface({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, tet, {});
  EXPECT_GE(ok.cells.size(), 1u);
}

TEST(Mesher, CommandWritesVtuMshAndSummary)
{
  const auto dir = scratch("mesher_cli");
  auto       r   = rectify_cli("mesh --opening 40um --out " + (dir / "m").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "m" / "summary.json");
  const auto    s = nlohmann::json::parse(in);
  for (const char *key : {"n_cells", "n_vertices", "min_dihedral_deg", "max_aspect_ratio",
                          "fluid_volume_m3", "exact_fluid_volume_m3", "gap_layers"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_NEAR(s["fluid_volume_m3"].get<double>() / s["exact_fluid_volume_m3"].get<double>(), 1, 1e-6);
  // Gmsh file: physical names and as many elements as faces + cells
  std::ifstream     msh(dir / "m" / "mesh.msh");
  std::stringstream text;
  text << msh.rdbuf();
  const std::string t = text.str();
  EXPECT_NE(t.find("$MeshFormat\n2.2 0 8"), std::string::npos);
  for (const char *name : {"2 1 \"inlet\"", "2 2 \"outlet\"", "2 3 \"walls\"", "2 4 \"reed\"", "3 10 \"fluid\""})
    EXPECT_NE(t.find(name), std::string::npos) << name;
  const auto elements = t.find("$Elements\n");
  ASSERT_NE(elements, std::string::npos);
  const std::size_t n_elements = std::stoul(t.substr(elements + 10));
  EXPECT_EQ(n_elements, s["n_cells"].get<std::size_t>() + s["surface_check"]["n_faces"].get<std::size_t>());
  EXPECT_TRUE(std::filesystem::exists(dir / "m" / "mesh.vtu"));
  EXPECT_TRUE(std::filesystem::exists(dir / "m" / "boundary.vtu"));

  // bad input: exit 2, the key named, no output folder
  r = rectify_cli("mesh --opening 1.95mm --out " + (dir / "bad").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("ceiling"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
}

// The valve drawn as an outline (issue 19): every example geometry
// (rounded, tapered, necked reeds; two ports; a slotted port) meshes with
// the fluid volume of its geometry, computed here independently: pocket +
// each port's mouth x its bore - the reed's area x thickness - the closed
// part of the gap, opening x integral of phi(s) w(s) (w the reed's chord at
// s, summed on 400 000 midpoints); the gap's volume likewise; the inlet's
// area the ports'; a closed, outward boundary; the bulk as isotropic as
// the rectangle's; every layered cell a third of a vertical prism.
TEST(Mesher, EveryExampleOutlineMeshesWithItsGeometrysVolume)
{
  const auto dir = std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases" / "geometries";
  for (const char *name : {"rounded-tip", "tapered", "necked", "two-ports", "slotted-port"})
    {
      const auto p        = MeshParameters::from_case(CaseFile::load(dir / (std::string(name) + ".toml")));
      const auto &g       = p.geometry;
      const auto outline  = g.reed_boundary();
      const auto shape    = p.sampled_shape();
      double     ports_volume = 0, ports_area = 0;
      for (const auto &port : g.ports())
        ports_volume += port.area_m2() * port.length_m, ports_area += port.area_m2();
      const auto integral = [&](double a, double b) {
        const int n = 400000;
        double    sum = 0;
        for (int k = 0; k < n; ++k)
          {
            const double x = a + (b - a) * (k + 0.5) / n;
            double       w = 0;
            for (const auto &[y0, y1] : geometry::chord_intervals(outline, x))
              w += y1 - y0;
            sum += shape(x) * w;
          }
        return sum * (b - a) / n;
      };
      for (double opening : {2e-6, 100e-6, 1e-3})
        {
          SCOPED_TRACE(std::string(name) + " at " + std::to_string(opening));
          const auto  r = mesh_valve(p, opening);
          const auto &i = r.info;
          const double closed = opening * integral(0, i.closed_to_m);
          const double gap    = opening * integral(i.closed_to_m, g.reed_length_m);
          const double fluid  = g.pocket_length_m * g.pocket_width_m * g.pocket_height_m + ports_volume -
                               g.reed_area_m2() * g.reed_thickness_m - closed;
          EXPECT_NEAR(i.fluid_volume_m3 / fluid, 1.0, 1e-9);
          EXPECT_NEAR(i.gap_volume_m3 / gap, 1.0, 1e-6); // the midpoint sums' own error
          EXPECT_NEAR(i.fluid_volume_m3 / i.exact_fluid_volume_m3, 1.0, 1e-12);
          EXPECT_NEAR(i.gap_volume_m3 / i.exact_gap_volume_m3, 1.0, 1e-9);
          EXPECT_TRUE(i.surface.closed && i.surface.outward && !i.surface.self_intersecting);
          EXPECT_NEAR(i.surface.volume_m3 / i.fluid_volume_m3, 1.0, 1e-9);
          // the circles' polygons keep pi r^2; a polygon port is its own outline
          EXPECT_NEAR(i.boundary_area_m2[inlet] / ports_area, 1.0, 1e-9);
          EXPECT_EQ(faces_of_one_cell(r.mesh).size(), r.mesh.boundary.size());
          EXPECT_GE(i.quality.region[bulk].min_dihedral_deg, 4.0);
          EXPECT_LE(i.quality.region[bulk].max_aspect_ratio, 15.0);
          for (std::size_t c = 0; c < r.mesh.cells.size(); ++c)
            ASSERT_GT(cell_volume(r.mesh, c), 0.0) << "inverted cell " << c;
        }
    }
}

// The reference rectangle drawn as an outline goes through the outline's
// code (its outline refined at the stations, classified by CGAL's side
// test) and gives the shorthand's mesh, vertex for vertex.
TEST(Mesher, TheReferenceRectangleDrawnAsAnOutlineGivesTheShorthandsMesh)
{
  const auto outline =
    MeshParameters::from_case(CaseFile::load(std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases/geometries/rectangle-outline.toml"));
  ASSERT_FALSE(outline.geometry.is_shorthand());
  for (double opening : {2e-6, 300e-6})
    {
      const auto a = mesh_valve(reference(), opening), b = mesh_valve(outline, opening);
      EXPECT_EQ(a.mesh.vertices, b.mesh.vertices) << opening;
      EXPECT_EQ(a.mesh.cells, b.mesh.cells) << opening;
      EXPECT_EQ(a.mesh.boundary.size(), b.mesh.boundary.size()) << opening;
    }
}

// The seat film's modal area over an outline (issue 19): the reference
// rectangle drawn as an outline gives the shorthand's; two ports and a
// rounded tip against a 2D midpoint sum over the seat (phi(x) over the
// reed less its ports, 2000 x 2000 cells).
TEST(Mesher, SeatFilmModalAreaOverAnyOutline)
{
  const auto dir  = std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases" / "geometries";
  const auto beam = mesher::ReedShape::beam(6.1e-3, 3.3e-3);
  const auto phi  = [&](double s) { return beam(std::min(s, 6.1e-3)); };
  const ValveGeometry shorthand;
  const auto          rectangle = ValveGeometry::from_case(CaseFile::load(dir / "rectangle-outline.toml"));
  EXPECT_NEAR(mesher::seat_film_modal_area_m2(rectangle, phi) / mesher::seat_film_modal_area_m2(shorthand, phi), 1.0,
              1e-6);
  for (const char *name : {"two-ports.toml", "rounded-tip.toml", "slotted-port.toml"})
    {
      const auto g       = ValveGeometry::from_case(CaseFile::load(dir / name));
      const auto outline = g.reed_boundary();
      const auto ports   = g.ports();
      double     y0 = 0, y1 = 0;
      for (const auto &p : outline)
        y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
      const int    n  = 2000;
      const double dx = g.reed_length_m / n, dy = (y1 - y0) / n;
      double       sum = 0;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
          {
            const geometry::XY q{(i + 0.5) * dx, y0 + (j + 0.5) * dy};
            if (geometry::side_of(outline, q) != geometry::Side::inside)
              continue;
            bool in_port = false;
            for (const auto &port : ports)
              in_port = in_port || port.contains(q);
            if (!in_port)
              sum += phi(q[0]) * dx * dy;
          }
      const double area = mesher::seat_film_modal_area_m2(g, phi);
      std::printf("%s: seat film modal area %.6g mm^2 (midpoint sum %.6g)\n", name, area * 1e6, sum * 1e6);
      EXPECT_NEAR(area / sum, 1.0, 2e-3) << name; // the midpoint sum's staircase edges: O(1 / n) of the edge's share
    }
}
