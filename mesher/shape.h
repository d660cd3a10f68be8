// The reed's deflected shape phi(s), s the distance from the clamp line, with
// phi(0) = 0 and phi(L) = 1: the underside is z = tip_opening * phi(s).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace rectify::mesher
{
  class ReedShape
  {
  public:
    /// The reference "beam" shape: Euler-Bernoulli cantilever of length L
    /// under a point load at s = a (reference-case.md sec. 1).
    static ReedShape beam(double length_m, double load_at_m);
    /// A table (s, phi) from the clamp to the tip, linearly interpolated and
    /// scaled so that phi(L) = 1. Throws InputError (naming `source`) unless
    /// s starts at 0, increases strictly, ends at L (to 1e-6 relative), phi
    /// starts at 0 and never decreases, and phi(L) > 0.
    static ReedShape table(std::vector<double> s, std::vector<double> phi, double length_m,
                           const std::string &source);
    /// Reads a CSV with columns s_m and phi (comment lines '#' allowed), such
    /// as the stiffness solver's shape.csv.
    static ReedShape from_csv(const std::filesystem::path &path, double length_m);

    double             operator()(double s) const;
    double             length() const { return length_; }
    const std::string &name() const { return name_; }

  private:
    std::string         name_;
    double              length_ = 0, load_at_ = 0;
    std::vector<double> s_, phi_; // empty for the beam
  };

  /// The shape as the mesher builds it: the piecewise-linear interpolant of
  /// phi on stations s_0 = 0 < ... < s_J = L spaced at most `spacing`. The
  /// floor triangulation has a line at every station, so the mesh reproduces
  /// this geometry exactly and its volumes are analytic (trapezoid rule).
  class SampledShape
  {
  public:
    /// Stations spaced evenly at most `spacing` apart, except that none lies
    /// within 0.3 spacing of a point in `avoid` (the mesher's port edges: a
    /// station line grazing the port would leave thin floor triangles).
    SampledShape(const ReedShape &shape, double spacing, const std::vector<double> &avoid = {});
    double                     operator()(double s) const; ///< for s in [0, L]; L beyond
    const std::vector<double> &stations() const { return s_; }
    const std::vector<double> &values() const { return phi_; }
    /// Integral of the sampled phi from 0 to station j.
    double integral_to_station(std::size_t j) const;
    /// Max |phi - sampled phi| (on 50 points per interval).
    double max_sampling_error() const { return max_error_; }

  private:
    std::vector<double> s_, phi_;
    double              max_error_ = 0;
  };
} // namespace rectify::mesher
