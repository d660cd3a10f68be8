// line_inertance: the oil in the outlet line has mass; accelerating it takes a
// pressure difference L dq/dt (L = rho l / A for a tube).
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_line_inertance()
  {
    return std::make_shared<Effect>(
      "line_inertance",
      "fluid inertance of the outlet line, L dq/dt in series with the line's resistance, fed "
      "through the outlet valve into the oil between valve and line",
      "the outlet flow lags the chamber: the outlet valve's pressure drop overshoots at each "
      "opening and the outlet pressure rings after each closing; grows with frequency",
      std::vector<EffectParameter>{{"lines", "outlet_inertance_Pa_s2_per_m3", 1e5, 1e9, true,
                                    "inertance of the outlet line (rho l / A)",
                                    // the outlet pressure rings at 1/(2 pi sqrt(L C)) after
                                    // each closing; the ringing's phase makes the residual
                                    // multimodal in L: start from 33 points (1.33x apart)
                                    33}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.lines.outlet_inertance_Pa_s2_per_m3 = v[0];
      });
  }
} // namespace rectify::diagnosis
