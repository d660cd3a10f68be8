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

} // namespace rectify::diagnosis
