// The residuals in words (words.h): a signal's shape as a sentence, a run's
// sentences, what a model leaves per signal.
#include <cmath>
#include <cstdio>

#include "common/case_file.h"
#include "diagnosis/words.h"

namespace rectify::diagnosis
{
  namespace
  {
    std::string pretty(const std::string &signal)
    {
      if (signal == "outlet_pressure_Pa")
        return "outlet pressure";
      if (signal == "chamber_pressure_Pa")
        return "chamber pressure";
      if (signal == "outlet_valve_m")
        return "outlet valve opening";
      if (signal == "actuator_position_m")
        return "actuator position";
      if (signal == "actuator_velocity_m_per_s")
        return "actuator velocity";
      return signal;
    }

    /// Value in the signal's display unit, with the unit.
    std::string in_units(const std::string &signal, double v)
    {
      char buf[64];
      if (signal.ends_with("_Pa"))
        std::snprintf(buf, sizeof buf, "%.3g MPa", v / 1e6);
      else if (signal == "outlet_valve_m")
        std::snprintf(buf, sizeof buf, "%.3g um", v * 1e6);
      else if (signal == "actuator_position_m")
        std::snprintf(buf, sizeof buf, "%.3g mm", v * 1e3);
      else if (signal == "actuator_velocity_m_per_s")
        std::snprintf(buf, sizeof buf, "%.3g mm/s", v * 1e3);
      else
        std::snprintf(buf, sizeof buf, "%.3g", v);
      return buf;
    }

    std::string percent(double fraction)
    {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.0f %%", 100 * fraction);
      return buf;
    }

  } // namespace

  std::string shape_words(const std::string &signal, const SignalShape &s)
  {
    const auto  &amp  = s.harmonic_amplitudes;
    const double most = std::max(s.half_fraction[0], s.half_fraction[1]);
    std::string  w    = "residual " + in_units(signal, s.rms) + " RMS (" + percent(s.rms_normalised) +
                    " of its swing), " + percent(most) + " of it in the " +
                    (s.half_fraction[0] >= s.half_fraction[1] ? "pressurising stroke" : "refill") + "; model " +
                    (s.bias > 0 ? "above" : "below") + " the data by " + in_units(signal, std::abs(s.bias)) +
                    " on average";
    w += "; per cycle the data swing " + in_units(signal, s.swing_data) + ", the model " +
         in_units(signal, s.swing_model);
    if (s.above_10th > 0.3)
      w += "; " + percent(s.above_10th) + " of the residual above the 10th harmonic (fast ringing)";
    else
      w += "; mostly at harmonic " + std::to_string(s.dominant_harmonic) + " (" +
           in_units(signal, amp.empty() ? 0.0 : amp[static_cast<std::size_t>(s.dominant_harmonic)]) + ")";
    const double growth = s.rms_by_third[0] > 0 ? s.rms_by_third[2] / s.rms_by_third[0] : 0;
    if (growth > 1.5)
      w += "; grows over the record (last third " + format_number(std::round(growth * 10) / 10) + " x the first)";
    else if (growth > 0 && growth < 1 / 1.5)
      w += "; fades over the record (start-up transient)";
    return w;
  }

  std::vector<std::string> localisation_words(const Localisation &L)
  {
    std::vector<std::string> out;
    for (const auto &[name, s] : L.signals)
      if (s.rms_normalised >= 0.03) // within a few percent of the swing: not worth a sentence of its own
        out.push_back(pretty(name) + ": " + shape_words(name, s));
    if (out.empty())
      out.push_back("every signal within 3 % of its swing: no clear disagreement");
    return out;
  }

  std::string residual_words(const SignalResidual &r)
  {
    char units[64];
    std::snprintf(units, sizeof units, ", %.3g noise units: ", r.noise_units);
    return pretty(r.signal) + units + shape_words(r.signal, r.shape);
  }
} // namespace rectify::diagnosis
