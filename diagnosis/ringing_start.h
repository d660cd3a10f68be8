// The start of a candidate whose first parameter sets a lightly damped
// ringing (an outlet line's length, EffectParameter::ringing_Hz): a stage of
// fitting a candidate (fit.h).
//
// Takes: the candidate's evaluator (search.h), whose runs hold the record.
// Gives: start points at the ringing frequencies the residual shows, best
// first, from grids along the baseline's parameters and searches along the
// valleys of constant ringing; empty where the residual shows no ringing in
// the parameter's range.
#pragma once

#include <string>
#include <vector>

#include "diagnosis/results.h"
#include "diagnosis/search.h"

namespace rectify::diagnosis
{
  /// The start points (see ringing_start.cpp for the method); counts its
  /// (short) runs of the model into runs_of_the_model; `log` says what
  /// became of each frequency it tried.
  std::vector<std::vector<double>> ringing_start(const Evaluator &ev, int &runs_of_the_model, RingingLog &log);
} // namespace rectify::diagnosis
