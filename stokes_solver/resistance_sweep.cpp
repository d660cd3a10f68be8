#include "stokes_solver/resistance_sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <memory>
#include <mutex>
#include <stdexcept>

#include <mpi.h>

#include "common/checkpoint.h"
#include "common/io.h"
#include "common/progress.h"
#include "maps/monotone_cubic.h"
#include "mesher/mesher.h"
#include "stokes_solver/thin_gap.h"

namespace rectify::stokes
{
  const std::vector<std::string> &OpeningPoint::columns()
  {
    static const std::vector<std::string> c{
      "opening_m",        "R_Pa_s_per_m3",          "R_dissipation_Pa_s_per_m3", "reed_force_N",
      "A_eff_m2",         "pressure_drop_Pa",       "R_thin_gap_Pa_s_per_m3",    "reynolds_port",
      "reynolds_gap_exit", "mass_balance_rel_error", "n_dofs",                    "iterations",
      "wall_time_s",      "R_energy_Pa_s_per_m3",   "dp_per_tip_velocity_Pa_s_per_m", "force_per_flow_Pa_s_per_m",
      "damping_N_s_per_m", "damping_fixed_dp_N_s_per_m", "A_modal_m2", "loading_asymmetry", "added_mass_kg",
      "swept_area_m2",    "loading_time_s", "mesh_time_s", "setup_time_s", "assembly_time_s", "solve_time_s"};
    return c;
  }

  std::vector<double> OpeningPoint::row() const
  {
    return {opening_m,         R_Pa_s_per_m3,          R_dissipation_Pa_s_per_m3, reed_force_N, A_eff_m2,
            pressure_drop_Pa,  R_thin_gap_Pa_s_per_m3, reynolds_port,             reynolds_gap_exit,
            mass_balance_rel_error, n_dofs,            iterations,                wall_time_s,
            R_energy_Pa_s_per_m3, dp_per_tip_velocity_Pa_s_per_m, force_per_flow_Pa_s_per_m, damping_N_s_per_m,
            damping_fixed_dp_N_s_per_m, A_modal_m2, loading_asymmetry, added_mass_kg, swept_area_m2, loading_time_s,
            mesh_time_s, setup_time_s, assembly_time_s, solve_time_s};
  }

  OpeningPoint OpeningPoint::from_row(const std::vector<double> &r)
  {
    OpeningPoint p;
    p.opening_m = r.at(0), p.R_Pa_s_per_m3 = r.at(1), p.R_dissipation_Pa_s_per_m3 = r.at(2);
    p.reed_force_N = r.at(3), p.A_eff_m2 = r.at(4), p.pressure_drop_Pa = r.at(5);
    p.R_thin_gap_Pa_s_per_m3 = r.at(6), p.reynolds_port = r.at(7), p.reynolds_gap_exit = r.at(8);
    p.mass_balance_rel_error = r.at(9), p.n_dofs = r.at(10), p.iterations = r.at(11), p.wall_time_s = r.at(12);
    p.R_energy_Pa_s_per_m3 = r.at(13), p.dp_per_tip_velocity_Pa_s_per_m = r.at(14);
    p.force_per_flow_Pa_s_per_m = r.at(15), p.damping_N_s_per_m = r.at(16), p.damping_fixed_dp_N_s_per_m = r.at(17);
    p.A_modal_m2 = r.at(18), p.loading_asymmetry = r.at(19), p.added_mass_kg = r.at(20), p.swept_area_m2 = r.at(21);
    p.loading_time_s = r.at(22);
    p.mesh_time_s = r.at(23), p.setup_time_s = r.at(24), p.assembly_time_s = r.at(25), p.solve_time_s = r.at(26);
    return p;
  }

  ReynoldsNumbers reynolds_numbers(const ValveGeometry &g, const FluidParameters &fluid, double Q)
  {
    // The port's: mean velocity Q / A over the hydraulic diameter 4 A / P
    // (the ports' areas and perimeters summed); the gap exit's: Q over the
    // reed's free edge (its perimeter less the clamp line: 2 L + W for the
    // rectangle).
    const double rho = fluid.density_kg_per_m3, mu = fluid.viscosity_Pa_s;
    double       perimeter = 0;
    for (const auto &port : g.ports())
      perimeter += port.perimeter_m();
    const auto   clamp = g.clamp_line_y();
    const double edge  = geometry::perimeter(g.reed_boundary()) - (clamp[1] - clamp[0]);
    return {4 * rho * Q / (perimeter * mu), 2 * rho * Q / (edge * mu)};
  }

  double thin_gap_R(const mesher::MeshParameters &mp, double closed_to_m, double opening, double mu)
  {
    // The gap is opening x phi(s): every conductance scales as opening^3, so
    // the gap's part of R is R_gap(x0) (x0 / x)^3 for one valve, shape,
    // closed part and viscosity (tests/test_stokes.cpp checks the scaling to
    // 1e-6). It is solved once per process at x0 = 100 um (under 1 s: a 310 k-cell
    // problem at two spacings) and scaled for every opening; a fixed x0 makes
    // the result the same whichever openings a process solves first.
    constexpr double           x0    = 100e-6;
    const mesher::SampledShape shape = mp.sampled_shape();
    const auto                &g     = mp.geometry;
    std::vector<double>        key   = {closed_to_m, mu};
    key.insert(key.end(), shape.stations().begin(), shape.stations().end());
    key.insert(key.end(), shape.values().begin(), shape.values().end());
    static std::mutex                    mutex;
    static std::map<std::string, double> gap_R_at_x0;
    const double          port = stokes::ports_bore_R(g, mu);
    const std::string     id   = csv_row(key) + g.to_json().dump();
    const std::lock_guard lock(mutex);
    auto                  it = gap_R_at_x0.find(id);
    if (it == gap_R_at_x0.end())
      it = gap_R_at_x0.emplace(id, thin_gap_valve_R(g, [&](double x) { return shape(x); }, x0, closed_to_m, mu, 10e-6) -
                                     port)
             .first;
    return it->second * std::pow(x0 / opening, 3) + port;
  }

  std::pair<double, double> interpolate_point(const std::vector<OpeningPoint> &points, double x)
  {
    std::vector<double> lx, lr, a;
    for (const auto &p : points)
      {
        lx.push_back(std::log(p.opening_m));
        lr.push_back(std::log(p.R_Pa_s_per_m3));
        a.push_back(p.A_eff_m2);
      }
    const maps::MonotoneCubic r_cubic(lx, lr), a_cubic(lx, a);
    return {std::exp(r_cubic.evaluate(std::log(x)).value), a_cubic.evaluate(std::log(x)).value};
  }

  ReedMotion reed_motion(const mesher::MeshParameters &mp)
  {
    const double L = mp.geometry.reed_length_m;
    return {[shape = mp.sampled_shape(), L](double px, double) { return shape(std::clamp(px, 0.0, L)); }, true};
  }

  nlohmann::json to_json(const FluidLoading &l)
  {
    return {{"K_QQ_Pa_s_per_m3", l.K_QQ_Pa_s_per_m3},
            {"K_Qv_Pa_s_per_m", l.K_Qv_Pa_s_per_m},
            {"K_vQ_Pa_s_per_m", l.K_vQ_Pa_s_per_m},
            {"K_vv_N_s_per_m", l.K_vv_N_s_per_m},
            {"asymmetry", l.asymmetry},
            {"A_modal_m2", l.A_modal_m2},
            {"damping_fixed_dp_N_s_per_m", l.damping_fixed_dp_N_s_per_m},
            {"swept_flow_m3_per_s", l.swept_flow_m3_per_s},
            {"outflow_b_m3_per_s", l.outflow_b_m3_per_s},
            {"mass_balance_b_rel_error", l.mass_balance_b_rel_error},
            {"reed_force_b_N", l.reed_force_b_N},
            {"added_mass_kg", l.added_mass_kg},
            {"added_mass_boundary_kg", l.added_mass_boundary_kg},
            {"potential_dofs", l.potential_dofs},
            {"solve_time_s", l.solve_time_s},
            {"meaning", "(dp, -F) = K (Q, v): Q the flow through the valve, v the reed's tip velocity, F the "
                        "modal force on the reed (its shape normalised to the tip); docs/fluid-loading.md"}};
  }

  OpeningPoint solve_opening(const mesher::MeshParameters &mp, const FlowParameters &fp, double x,
                             const MpiSession &mpi)
  {
    const auto         valve   = mesher::mesh_valve(mp, x, false);
    const ReedMotion   motion  = reed_motion(mp);
    const bool         loading = fp.settings.reed_loading == "solve";
    const StokesResult r = solve_stokes(valve.mesh, fp, {}, false, loading ? &motion : nullptr, mpi.comm());
    OpeningPoint        p;
    p.opening_m                 = x;
    p.R_Pa_s_per_m3             = r.R_pressure_Pa_s_per_m3;
    p.R_dissipation_Pa_s_per_m3 = r.R_dissipation_Pa_s_per_m3;
    p.reed_force_N              = r.reed_force_N[2];
    p.A_eff_m2                  = r.A_eff_m2;
    p.pressure_drop_Pa          = r.inlet_pressure_Pa - r.outlet_pressure_Pa;
    p.R_thin_gap_Pa_s_per_m3    = thin_gap_R(mp, valve.info.closed_to_m, x, fp.fluid.viscosity_Pa_s);
    const auto re               = reynolds_numbers(mp.geometry, fp.fluid, fp.settings.flow_rate_m3_per_s);
    p.reynolds_port             = re.port;
    p.reynolds_gap_exit         = re.gap_exit;
    p.mass_balance_rel_error = r.mass_balance_rel_error;
    p.n_dofs                 = static_cast<double>(r.n_dofs);
    p.iterations             = r.iterations;
    p.wall_time_s            = r.wall_time_s;
    p.mesh_time_s            = valve.info.wall_time_s;
    p.setup_time_s           = r.setup_time_s;
    p.assembly_time_s        = r.assembly_time_s;
    p.solve_time_s           = r.solve_time_s;
    if (loading)
      {
        const auto &l                    = r.loading;
        p.R_energy_Pa_s_per_m3           = l.K_QQ_Pa_s_per_m3;
        p.dp_per_tip_velocity_Pa_s_per_m = l.K_Qv_Pa_s_per_m;
        p.force_per_flow_Pa_s_per_m      = l.K_vQ_Pa_s_per_m;
        p.damping_N_s_per_m              = l.K_vv_N_s_per_m;
        p.damping_fixed_dp_N_s_per_m     = l.damping_fixed_dp_N_s_per_m;
        p.A_modal_m2                     = l.A_modal_m2;
        p.loading_asymmetry              = l.asymmetry;
        p.added_mass_kg                  = l.added_mass_kg;
        p.swept_area_m2                  = l.swept_flow_m3_per_s;
        p.loading_time_s                 = l.solve_time_s;
      }
    // Every process holds the root's numbers (the sums are reduced, but the
    // thin-gap estimate and timings are each process's own).
    return OpeningPoint::from_row(mpi.broadcast(p.row()));
  }

  namespace
  {
    /// Openings solved at most once: from the root's checkpoint, else solved
    /// and appended to it at once. Every process calls it with the same openings.
    class CheckpointedOpenings
    {
    public:
      CheckpointedOpenings(const mesher::MeshParameters &mp, const FlowParameters &fp,
                           const std::filesystem::path &dir, const std::string &name,
                           const nlohmann::json &fingerprint, const MpiSession &mpi, const std::string &label,
                           std::size_t n_planned)
        : mp_(mp)
        , fp_(fp)
        , mpi_(mpi)
        , root_(mpi.rank() == 0)
      {
        const auto  columns = OpeningPoint::columns();
        std::string header;
        for (const auto &c : columns)
          header += (header.empty() ? "" : ",") + c;
        std::vector<double> flat;
        if (root_)
          {
            ensure_directory(dir);
            checkpoint_ = std::make_unique<Checkpoint>(dir, name, fingerprint, header);
            for (const auto &line : checkpoint_->finished_rows())
              {
                const auto csv = parse_csv(header + "\n" + line + "\n", (dir / (name + ".csv")).string());
                flat.insert(flat.end(), csv.rows[0].begin(), csv.rows[0].end());
              }
          }
        flat = mpi.broadcast(flat);
        for (std::size_t i = 0; i + columns.size() <= flat.size(); i += columns.size())
          done_[flat[i]] = OpeningPoint::from_row({flat.begin() + static_cast<long>(i),
                                                   flat.begin() + static_cast<long>(i + columns.size())});
        progress_  = std::make_unique<Progress>(label, n_planned, 0, !root_);
      }

      /// All of `openings`: those not in the checkpoint solved one per
      /// process while there are at least as many as processes (independent
      /// solves scale; one solve split over two ranks is bandwidth-bound),
      /// the rest on all processes together. Each wave's results reach
      /// every process and the checkpoint before the next wave starts.
      const std::map<double, OpeningPoint> &solve_all(const std::vector<double> &openings)
      {
        std::vector<double> todo;
        for (double x : openings)
          if (done_.count(x) != 0)
            reuse();
          else if (std::find(todo.begin(), todo.end(), x) == todo.end())
            todo.push_back(x);
        const std::size_t n = mpi_.size();
        std::size_t       next = 0;
        for (; n > 1 && todo.size() - next >= n; next += n)
          {
            const std::vector<double> wave(todo.begin() + static_cast<long>(next),
                                           todo.begin() + static_cast<long>(next + n));
            const auto [points, error] = solve_one_each(wave);
            for (const auto &p : points)
              record(p); // what the wave finished stays in the checkpoint
            if (!error.empty())
              throw std::runtime_error(error);
          }
        for (; next < todo.size(); ++next)
          record(solve_opening(mp_, fp_, todo[next], mpi_));
        return done_;
      }

      void        extend(std::size_t more) { progress_->extend(more); }
      std::size_t n_reused() const { return n_reused_; } ///< openings taken from the checkpoint so far

    private:
      void reuse()
      {
        if (root_)
          progress_->skip();
        ++n_reused_;
      }

      /// Checks a solved opening, appends it to the checkpoint and reports it.
      void record(const OpeningPoint &p)
      {
        const double x = p.opening_m;
        if (!(p.R_Pa_s_per_m3 > 0) || !(p.A_eff_m2 > 0))
          throw std::runtime_error("the Stokes solution at " + format_number(x) + " m gives R = " +
                                   format_number(p.R_Pa_s_per_m3) + ", A_eff = " + format_number(p.A_eff_m2));
        if (root_)
          {
            checkpoint_->append(csv_row(p.row()));
            char what[200];
            std::snprintf(what, sizeof(what), "%.4g um: R = %.4e Pa s/m^3, A_eff = %.3f mm^2, %.0f DoFs, %.1f s",
                          x * 1e6, p.R_Pa_s_per_m3, p.A_eff_m2 * 1e6, p.n_dofs, p.wall_time_s);
            progress_->step(what);
          }
        done_[x] = p;
      }

      /// wave[r] solved on process r alone; every process gets all that
      /// succeeded and the first failure's message (empty if none).
      std::pair<std::vector<OpeningPoint>, std::string> solve_one_each(const std::vector<double> &wave) const
      {
        const auto          columns = OpeningPoint::columns().size();
        std::vector<double> mine(columns, 0.0);
        std::string         error;
        try
          {
            mine = solve_opening(mp_, fp_, wave[mpi_.rank()], MpiSession::on(MPI_COMM_SELF)).row();
          }
        catch (const std::exception &e)
          {
            error = e.what();
          }
        constexpr std::size_t message = 1000;
        error.resize(message, '\0');
        std::vector<double> rows(columns * wave.size());
        std::string         errors(message * wave.size(), '\0');
        MPI_Allgather(mine.data(), static_cast<int>(columns), MPI_DOUBLE, rows.data(), static_cast<int>(columns),
                      MPI_DOUBLE, mpi_.comm());
        MPI_Allgather(error.data(), static_cast<int>(message), MPI_CHAR, errors.data(), static_cast<int>(message),
                      MPI_CHAR, mpi_.comm());
        std::vector<OpeningPoint> points;
        std::string               first_error;
        for (std::size_t r = 0; r < wave.size(); ++r)
          {
            if (errors[r * message] != '\0')
              {
                if (first_error.empty())
                  first_error = errors.substr(r * message, message).c_str();
                continue;
              }
            points.push_back(OpeningPoint::from_row(
              {rows.begin() + static_cast<long>(r * columns), rows.begin() + static_cast<long>((r + 1) * columns)}));
          }
        return {points, first_error};
      }

      const mesher::MeshParameters  &mp_;
      const FlowParameters          &fp_;
      const MpiSession              &mpi_;
      const bool                     root_;
      std::unique_ptr<Checkpoint>    checkpoint_;
      std::unique_ptr<Progress>      progress_;
      std::map<double, OpeningPoint> done_;
      std::size_t                    n_reused_ = 0;
    };
  } // namespace

  std::vector<OpeningPoint> fixed_resistance_sweep(const mesher::MeshParameters &mp, const FlowParameters &fp,
                                                   const std::vector<double> &openings,
                                                   const std::filesystem::path &dir, const nlohmann::json &fingerprint,
                                                   const MpiSession &mpi, std::size_t *n_resumed)
  {
    CheckpointedOpenings      solver(mp, fp, dir, "map-partial", fingerprint, mpi, "map-resistance", openings.size());
    std::vector<OpeningPoint> points;
    const auto               &all = solver.solve_all(openings);
    for (double x : openings)
      points.push_back(all.at(x));
    if (n_resumed != nullptr)
      *n_resumed = solver.n_reused();
    return points;
  }

  std::vector<double> initial_openings(const SweepSettings &s)
  {
    std::vector<double> x;
    for (unsigned k = 0; k < s.initial_openings; ++k)
      x.push_back(k + 1 == s.initial_openings ?
                    s.to_m :
                    s.from_m * std::pow(s.to_m / s.from_m, static_cast<double>(k) / (s.initial_openings - 1)));
    return x;
  }

  SweepPlan plan_resistance_sweep(const SweepSettings &s, const std::map<double, OpeningPoint> &available)
  {
    SweepPlan                      plan;
    std::map<double, OpeningPoint> solved; // this sweep's points, in the order the sweep takes them
    const auto sorted = [&]() {
      std::vector<OpeningPoint> v;
      for (const auto &[x, p] : solved)
        v.push_back(p);
      return v;
    };
    // Takes the openings of one round from `available`; false (and the
    // missing ones in the plan) if any is not there.
    const auto take = [&](const std::vector<double> &round) {
      for (double x : round)
        if (!available.contains(x))
          plan.missing.push_back(x);
      return plan.missing.empty();
    };

    // The coarse log grid.
    const auto grid = initial_openings(s);
    if (!take(grid))
      return plan;
    for (double x : grid)
      solved[x] = available.at(x);
    // Check every interval by its geometric midpoint; split those that fail.
    std::vector<std::pair<double, double>> todo;
    {
      const auto v = sorted();
      for (std::size_t i = 0; i + 1 < v.size(); ++i)
        todo.emplace_back(v[i].opening_m, v[i + 1].opening_m);
    }
    const auto too_short = [&](double a, double b, std::size_t n_solved) {
      return b / a < s.min_ratio * s.min_ratio || n_solved >= s.max_openings;
    };
    while (!todo.empty())
      {
        // The round's midpoints: known before any of them is solved.
        std::vector<double> round;
        {
          std::set<double> keys;
          for (const auto &[x, p] : solved)
            keys.insert(x);
          for (const auto &[a, b] : todo)
            if (!too_short(a, b, keys.size()))
              {
                round.push_back(std::sqrt(a * b));
                keys.insert(round.back());
              }
        }
        if (!take(round))
          return plan;
        // The checks, in the order of the intervals: each midpoint against
        // the interpolant through the points solved before it.
        std::vector<std::pair<double, double>> next;
        for (const auto &[a, b] : todo)
          {
            if (too_short(a, b, solved.size()))
              {
                // Too short to split, or out of solves: leave it unchecked but say so.
                plan.result.checks.push_back({a, b, std::sqrt(a * b), 0, 0, false, true});
                plan.result.converged = false;
                continue;
              }
            const double m = std::sqrt(a * b);
            const auto [R_interp, A_interp] = interpolate_point(sorted(), m);
            const OpeningPoint &p = solved[m] = available.at(m);
            const double eR = std::abs(R_interp / p.R_Pa_s_per_m3 - 1);
            const double eA = std::abs(A_interp / p.A_eff_m2 - 1);
            const bool   ok = eR <= s.tolerance && eA <= s.tolerance;
            plan.result.checks.push_back({a, b, m, eR, eA, ok, false});
            if (ok)
              {
                plan.result.max_R_error = std::max(plan.result.max_R_error, eR);
                plan.result.max_A_error = std::max(plan.result.max_A_error, eA);
              }
            else
              {
                next.emplace_back(a, m);
                next.emplace_back(m, b);
              }
          }
        todo = std::move(next);
      }
    plan.result.points = sorted();
    return plan;
  }

  SweepResult resistance_sweep(const mesher::MeshParameters &mp, const FlowParameters &fp, const SweepSettings &s,
                               const std::filesystem::path &dir, const nlohmann::json &fingerprint,
                               const MpiSession &mpi)
  {
    CheckpointedOpenings           solver(mp, fp, dir, "openings-partial", fingerprint, mpi, "design: openings",
                                          s.initial_openings);
    std::map<double, OpeningPoint> solved;
    for (bool first = true;; first = false)
      {
        SweepPlan plan = plan_resistance_sweep(s, solved);
        if (plan.complete())
          {
            plan.result.n_resumed = solver.n_reused();
            return plan.result;
          }
        if (!first)
          solver.extend(plan.missing.size());
        const auto &all = solver.solve_all(plan.missing);
        for (double x : plan.missing)
          solved[x] = all.at(x);
      }
  }
} // namespace rectify::stokes
