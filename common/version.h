// The tool's version and the source revision it was built from (git
// describe at configure time, "unknown" outside git). The revision lives in
// one generated source file, so a new commit recompiles that file alone.
#pragma once

namespace rectify
{
  const char *source_revision();
} // namespace rectify
