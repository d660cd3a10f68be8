#!/usr/bin/env bash
# Lists the functions longer than a limit (default 100 lines) in the sources
# outside tests, longest first: "lines  file:line  name".
#   bash scripts/long_functions.sh [LIMIT] [DIR ...]
# Needs Universal Ctags (Debian's universal-ctags). Lambdas count as their own
# functions and also inside the function that holds them.
set -euo pipefail
limit=${1:-100}
shift || true
cd "$(dirname "$0")/.."
dirs=("$@")
if [ ${#dirs[@]} -eq 0 ]; then
  dirs=(app common design diagnosis maps mesher stiffness_solver stokes_solver system whatif)
fi
command -v ctags >/dev/null || { echo "long_functions.sh: ctags not found (apt-get install universal-ctags)" >&2; exit 1; }
find "${dirs[@]}" \( -name '*.cpp' -o -name '*.h' \) -print0 |
  xargs -0 ctags --sort=no --languages=C++ --c++-kinds=f --fields=+ne -o - |
  awk -F'\t' -v limit="$limit" '
    { line = ""; end = ""
      for (i = 4; i <= NF; i++) {
        if ($i ~ /^line:/) line = substr($i, 6)
        if ($i ~ /^end:/) end = substr($i, 5)
      }
      if (line != "" && end != "" && end - line + 1 > limit)
        printf "%5d  %s:%s  %s\n", end - line + 1, $2, line, ($1 ~ /^__anon/ ? "(lambda)" : $1)
    }' | sort -rn
