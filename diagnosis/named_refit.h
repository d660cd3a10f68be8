// Refining the named effect (a stage of diagnose(), after naming): the
// residual scales hold the model's response to the drive's noise, computed
// so far with the model as it was; the named effect can change that
// response many-fold (a soft outlet seal turns the outlet valve's jitter
// into outlet pressure's), which weighs the signals wrongly and biases the
// parameter. So the noise is recalibrated with the fitted model and the fit
// repeated locally until the parameters settle (iteratively reweighted least
// squares); before that, the baseline parameters its fit determines are
// freed and the start and settling window chosen again with it; once
// settled, the parameters the case leaves out are tried on; where a gap is
// left, the effect's own shape is freed; then its parameters' uncertainty,
// a better side of a profile taken; a partner that splits its combined
// quantity held at the case's value.
//
// Takes: the diagnosis's context (its runs may get a new start and settling
// window), the named candidate's fit and its evaluator (every training
// cycle, its runs at once).
// Gives: the round's result refined (values, gain, baseline, freed and
// left-out parameters, refine passes, uncertainty, profile moves, held
// partner); the context's current predictions those of the last refit.
#pragma once

#include "diagnosis/context.h"
#include "diagnosis/search.h"

namespace rectify::diagnosis
{
  /// `left_out_tried`: the parameters the case leaves out were tried on
  /// before naming it (the nearest miss judged again).
  void refine_named(Context &x, RoundResult &rr, const CandidateResult &named, Evaluator ev, bool left_out_tried);
} // namespace rectify::diagnosis
