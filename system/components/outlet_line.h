// line_inertance: the outlet line's inertance ([lines]
// outlet_inertance_Pa_s2_per_m3 L, outlet_line_segments n), as a line of the
// case's bore added between the outlet valve and the high side: a line that
// has mass also has friction and oil. Laminar and quasi-steady (Womersley
// number r sqrt(w rho / mu) about 0.3 at 100 Hz for this oil), so
// L = 4/3 rho l / A and the line is l = 3 L A / (4 rho) long; its Poiseuille
// resistance joins R3, and its oil's compliance A l / beta is split over n pi
// sections (one is valid while l is well below a quarter wavelength at the
// harmonics that matter, about 0.4 m at 500 Hz).
//
// The valve discharges into the node after it, not through R3 into the high
// side: without a volume there a closing valve would stop the line's flow
// through none at all (a spike of GPa). That node's oil is a tenth of the
// high side's (taken from it, so the total stays the thesis's and L -> 0 is
// the thesis's model again) and half of the first section's. With node k's
// pressure p_k (node n: the high side) and segment k's flow q_k (q_-1: the
// valve's):
//   C_k p_k' = q_(k-1) - q_k,   (L / n) q_k' = p_k - p_(k+1) - (R3 / n) q_k,
// the high side filled by q_(n-1). Its states: state::line_segment_flow(k)
// and state::line_segment_node(k).
#pragma once

#include <cmath>
#include <memory>
#include <string>

#include "system/component.h"
#include "system/model.h"

namespace rectify::system
{
  class OutletLine : public Component
  {
  public:
    /// `thesis`: the model's constants before any component adjusted them.
    OutletLine(const SystemParameters &p, const ModelConstants &thesis)
      : L_(p.lines.outlet_inertance_Pa_s2_per_m3)
      , n_(static_cast<std::size_t>(p.lines.outlet_line_segments))
    {
      const double d = p.lines.diameter_m, A = M_PI * d * d / 4.0;
      length_        = 3.0 * L_ * A / (4.0 * p.fluid.density_kg_per_m3);
      added_R_       = 128.0 * p.fluid.viscosity_Pa_s * length_ / (M_PI * d * d * d * d);
      const double n = static_cast<double>(n_);
      half_C_        = 0.5 * A * length_ / thesis.beta_eff / n;
      half_V_        = 0.5 * A * length_ / n;
      C_node_        = 0.1 * thesis.C_h + half_C_;
      V_node_        = 0.1 * thesis.V_h + half_V_;
      C_between_     = A * length_ / thesis.beta_eff / n;
      V_between_     = A * length_ / n;
    }
    static std::shared_ptr<const Component> make(const SystemParameters &p, Scenario, const ModelConstants &thesis)
    {
      return p.lines.outlet_inertance_Pa_s2_per_m3 > 0 ? std::make_shared<OutletLine>(p, thesis) : nullptr;
    }

    std::string_view name() const override { return "line_inertance"; }

    /// The high side gives the node its tenth and the last section's half;
    /// R3 takes the added line's resistance.
    void adjust(ModelConstants &c) const override
    {
      const double C0 = 0.1 * c.C_h;
      c.C_h -= C0;
      const double V0 = 0.1 * c.V_h;
      c.V_h -= V0;
      c.R3 += added_R_;
      c.C_h += half_C_;
      c.V_h += half_V_;
    }
    void constants_json(nlohmann::json &j) const override
    {
      j["outlet_line_node_capacitance_m3_per_Pa"] = C_node_;
      j["added_outlet_line_length_m"]             = length_;
    }

    std::optional<std::size_t> outlet_node() const override { return state::line_node_p; }
    double high_side_inflow(std::span<const double> y) const override { return y[state::line_segment_flow(n_ - 1)]; }
    std::vector<std::size_t> flow_reads() const override
    {
      return {state::line_node_p, state::line_segment_flow(n_ - 1)};
    }
    std::size_t extra_states() const override { return 2 * (n_ - 1); }
    std::vector<OilVolume> volumes() const override
    {
      std::vector<OilVolume> v;
      for (std::size_t k = 0; k < n_; ++k)
        v.push_back({state::line_segment_node(k), k == 0 ? C_node_ : C_between_, k == 0 ? V_node_ : V_between_,
                     "outlet line node " + std::to_string(k), true});
      return v;
    }
    /// Order 2 with several sections: a short line's sections ring lightly
    /// damped at 10^5-10^7 Hz, where BDF orders 3-5 are unstable and CVODE
    /// falls to tiny steps (857 k steps for a 150 Hz record at L = 1e4, 62 k
    /// at order 2; a long line: 36 k vs 64 k).
    int max_bdf_order() const override { return n_ > 1 ? 2 : 0; }

    void typical_sizes(std::span<double> s, double flow, double pressure) const override
    {
      for (std::size_t k = 0; k < n_; ++k)
        {
          s[state::line_segment_flow(k)] = flow;
          s[state::line_segment_node(k)] = pressure;
        }
    }
    void own_rhs(double, std::span<const double> y, const Model &model, const Flows &f,
                 std::span<double> ydot) const override
    {
      const double nn = static_cast<double>(n_), R3 = model.constants().R3;
      for (std::size_t k = 0; k < n_; ++k)
        {
          const std::size_t iq = state::line_segment_flow(k), ip = state::line_segment_node(k);
          const double      p_next = k + 1 < n_ ? y[state::line_segment_node(k + 1)] : y[state::high_p];
          ydot[iq]                 = (y[ip] - p_next - R3 / nn * y[iq]) / (L_ / nn);
          const double q_in        = k == 0 ? f.q_outlet : y[state::line_segment_flow(k - 1)];
          const double C = k == 0 ? C_node_ + V_node_ * model.gas_compliance(y[ip]) :
                                    C_between_ + V_between_ * model.gas_compliance(y[ip]);
          ydot[ip] = (q_in - y[iq]) / C;
        }
    }
    void own_reads(std::vector<std::vector<std::size_t>> &r, const std::vector<std::size_t> &flow) const override
    {
      for (std::size_t k = 0; k < n_; ++k)
        {
          const std::size_t iq = state::line_segment_flow(k), ip = state::line_segment_node(k);
          r[iq] = {ip, iq, k + 1 < n_ ? state::line_segment_node(k + 1) : std::size_t(state::high_p)};
          if (k == 0)
            {
              r[ip] = flow; // the valve's flow
              r[ip].insert(r[ip].end(), {ip, iq});
            }
          else
            r[ip] = {state::line_segment_flow(k - 1), iq, ip};
        }
    }

    /// The chain's lowest frequency with both valves shut [Hz]: its n
    /// segments (L / n each) between the node after the valve, the nodes
    /// between segments and the high side (with the seal: `c`'s C_h),
    /// lossless, without free air; 1 / (2 pi sqrt(L C)) with C the node's
    /// and the high side's compliances in series for one segment.
    double ringing_Hz(const ModelConstants &c) const;

    double      inertance() const { return L_; }
    std::size_t segments() const { return n_; }
    double      added_length_m() const { return length_; }
    /// The node after the valve: its compliance and oil volume.
    double      node_compliance() const { return C_node_; }
    double      node_oil_volume() const { return V_node_; }
    /// Each node between two segments: a segment's oil.
    double      between_compliance() const { return C_between_; }

  private:
    double      L_;
    std::size_t n_;
    double      length_ = 0, added_R_ = 0, half_C_ = 0, half_V_ = 0;
    double      C_node_ = 0, V_node_ = 0, C_between_ = 0, V_between_ = 0;
  };

  /// The outlet line among c's components, or nullptr without one.
  const OutletLine *outlet_line(const ModelConstants &c);
  /// Its ringing_Hz (0 without the line).
  double outlet_line_ringing_Hz(const ModelConstants &c);
} // namespace rectify::system
