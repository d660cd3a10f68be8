#include "diagnosis/verdict.h"

#include <algorithm>
#include <cstdio>

#include "diagnosis/effect.h"
#include "diagnosis/results.h"
#include "diagnosis/fit.h"

namespace rectify::diagnosis
{
  std::vector<AbsorbedEffect> absorbed_by_baseline(const std::vector<std::shared_ptr<const Effect>> &library,
                                                   const system::SystemParameters &case_parameters,
                                                   const system::SystemParameters &fitted, double factor)
  {
    std::vector<AbsorbedEffect> out;
    for (const auto &e : library)
      if (const auto *c = e->combination())
        {
          const double at_case = c->value(case_parameters), at_fit = c->value(fitted);
          if (!(at_case > 0 && at_fit > factor * at_case))
            continue;
          AbsorbedEffect a{e->name(), c->name, c->meaning, at_case, at_fit, {}};
          // the [uncertain] parameters the quantity moves with, at the fit
          for (const auto &q : case_parameters.uncertain)
            {
              auto    moved = fitted;
              double *v     = moved.real_field(q.table, q.key);
              if (!v)
                continue;
              const double was = *v;
              *v = was != 0 ? 1.01 * was : q.lower + 0.01 * (q.upper - q.lower);
              if (c->value(moved) != at_fit)
                a.set_by.emplace_back(q.name(), was);
            }
          out.push_back(std::move(a));
        }
    return out;
  }

  std::string to_string(Verdict v)
  {
    switch (v)
      {
        case Verdict::explained:
          return "explained";
        case Verdict::partly_explained:
          return "partly explained";
        case Verdict::no_missing_effect:
          return "no missing effect";
        case Verdict::beyond_library:
          return "beyond the library";
      }
    return "";
  }

  Verdict verdict_of(bool effect_named, double residual_after, double floor_units)
  {
    if (effect_named)
      return residual_after <= floor_units ? Verdict::explained : Verdict::partly_explained;
    return residual_after <= floor_units ? Verdict::no_missing_effect : Verdict::beyond_library;
  }

  double explained_fraction(double residual_baseline, double residual_after)
  {
    const auto gap = [](double r) { return gap_above_noise(r * r); };
    return gap(residual_baseline) > 0 ? std::clamp(1.0 - gap(residual_after) / gap(residual_baseline), 0.0, 1.0)
                                      : 0.0;
  }

  std::string verdict_sentence(Verdict v, const std::string &named_effect, double baseline, double after,
                               double floor_units, double explained, const std::string &where)
  {
    char buf[512];
    switch (v)
      {
        case Verdict::explained:
          if (gap_above_noise(baseline * baseline) > 0)
            std::snprintf(buf, sizeof buf,
                          "%s explains the gap: residual %.3g noise units with the calibrated baseline alone, "
                          "%.3g with it (%.0f %% of the gap above the noise closed)",
                          named_effect.c_str(), baseline, after, 100 * explained);
          else // named on its training part; over the whole record the baseline was within the noise
            std::snprintf(buf, sizeof buf,
                          "%s explains the gap on the fitted part; over the whole record the calibrated baseline "
                          "alone already left %.3g noise units (within the noise), %.3g with it",
                          named_effect.c_str(), baseline, after);
          break;
        case Verdict::partly_explained:
          std::snprintf(buf, sizeof buf,
                        "%s explains %.0f %% of the gap above the noise (residual %.3g -> %.3g noise units); "
                        "%.3g noise units remain, more than %.3g: model error beyond the library. Largest "
                        "remaining residual: %s",
                        named_effect.c_str(), 100 * explained, baseline, after, after, floor_units, where.c_str());
          break;
        case Verdict::no_missing_effect:
          std::snprintf(buf, sizeof buf, "the calibrated baseline leaves %.3g noise units (at most %.3g)", after,
                        floor_units);
          break;
        case Verdict::beyond_library:
          std::snprintf(buf, sizeof buf,
                        "no effect of the library earns its parameters, and %.3g noise "
                        "units remain after the baseline fit (more than %.3g). Largest remaining residual: %s",
                        after, floor_units, where.c_str());
          break;
      }
    return buf;
  }

  std::string absorbed_sentence(const AbsorbedEffect &a)
  {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "; the calibrated baseline holds %s at %.3g, %.2g x the case's %.3g (%s): as much as "
                  "%s adding %.3g to the case's would, and this record cannot tell the two apart",
                  a.quantity.c_str(), a.fitted, a.fitted / a.case_value, a.case_value, a.meaning.c_str(),
                  a.effect.c_str(), a.fitted - a.case_value);
    std::string out = buf;
    if (a.set_by.empty())
      return out;
    std::string keys;
    for (std::size_t i = 0; i < a.set_by.size(); ++i)
      {
        std::snprintf(buf, sizeof buf, "%s%s (fitted %.3g)", i == 0 ? "" : i + 1 == a.set_by.size() ? " and " : ", ",
                      a.set_by[i].first.c_str(), a.set_by[i].second);
        keys += buf;
      }
    return out + ". To tell them apart, measure " + keys +
           " on the rig and give the case those values (or narrow their [uncertain] ranges to what is measured): "
           "the rest is then " + a.effect + "'s";
  }
} // namespace rectify::diagnosis
