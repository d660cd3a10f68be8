// line_inertance: the oil in the outlet line has mass; accelerating it takes a
// pressure difference L dq/dt. L is that of a line of the case's bore added
// between valve and high side (L = 4/3 rho l / A, laminar), which brings its
// Poiseuille resistance and its oil's compliance with it (system/model.cpp).
// The line is a hose: 12 pi sections, which the effect sets (and writes
// into the new case file) whatever the case's [lines] outlet_line_segments,
// which is for the case's own short line, the outlet passage.
// The range's lower end, 1e4, is the line switched off (L = 0): "no effect"
// must be in the range, and no inertance is small enough to be none in every
// run - with the widest uncertain bore (least line resistance) a loaded run
// still moves 27 % of its swing at L = 1e5 and 1.9 % at 1e4 (the line's flow
// lags by L / R3), while below 1e4 a line of several sections is tens of um
// long and rings at MHz, which CVODE cannot afford. The step from 1e4 to off
// is that last 1.9 % at most (0.07 % at the case's bore in a no-flow run).
#include <cmath>
#include <numbers>

#include "diagnosis/effect.h"
#include "system/components/outlet_line.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_line_inertance()
  {
    constexpr double off_below = 1e4; // the range's lower end: there the line is off
    // A hose carries its waves: 12 pi sections (its lowest three modes
    // within 0.3, 1.1 and 2.3 % of a continuous line's), whatever the case
    // gives its own short line
    // (the outlet passage, one lumped section in the reference case).
    constexpr long hose_sections = 12;
    return std::make_shared<Effect>(
      "line_inertance",
      "fluid inertance of the outlet line, L dq/dt in series with the line's resistance, fed "
      "through the outlet valve into the oil between valve and line; L is that of an added length "
      "of line of the case's bore (4/3 rho l / A), whose resistance and oil compliance come with it",
      "the outlet flow lags the chamber: the outlet valve's pressure drop overshoots at each "
      "opening and the outlet pressure rings after each closing; grows with frequency",
      std::vector<EffectParameter>{{"lines", "outlet_inertance_Pa_s2_per_m3", off_below, 1e9, true,
                                    "inertance of the outlet line (4/3 rho l / A)", 12, // 0.42 decade apart, as 9 over 1e5..1e9
                                    // with the outlet valve closed the line's oil swings
                                    // between the node and the high side (through the
                                    // line's own sections if it has several)
                                    [](double L, const system::SystemParameters &base) {
                                      auto p = base;
                                      p.lines.outlet_inertance_Pa_s2_per_m3 = L;
                                      p.lines.outlet_line_segments          = hose_sections;
                                      return system::outlet_line_ringing_Hz(
                                        system::ModelConstants(p, system::Scenario::no_flow));
                                    }}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.lines.outlet_inertance_Pa_s2_per_m3 = v[0] > off_below * (1 + 1e-9) ? v[0] : 0.0;
        p.lines.outlet_line_segments          = hose_sections;
      },
      std::vector<Effect::FixedKey>{{"lines", "outlet_line_segments", std::to_string(hose_sections)}});
  }
} // namespace rectify::diagnosis
