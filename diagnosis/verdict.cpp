#include <algorithm>

#include "diagnosis/diagnose.h"

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
} // namespace rectify::diagnosis
