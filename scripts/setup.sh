#!/usr/bin/env bash
# Installs the Debian packages rectify needs (only those missing; safe to run
# again) and builds everything into build/ (the tool is build/bin/rectify).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ccache pkg-config
  dpkg-dev               # dpkg-source: scripts/cvode.sh unpacks Debian's SUNDIALS source
  xz-utils               # the source archive is .tar.xz
  libsundials-dev        # CVODE: the stiff ODE integrator of the system model
  libeigen3-dev          # small dense LU inside CVODE's Newton iteration
  nlohmann-json3-dev     # summary.json and map metadata
  libtoml11-dev          # case files
  libcli11-dev           # the command line
  libdeal.ii-dev         # finite elements: reed elasticity (ARPACK, UMFPACK inside)
  libtet1.5-dev          # TetGen as a library: the pocket's tetrahedra
  libcgal-dev            # CGAL: planar meshing, surface checks (mesher)
  openmpi-bin            # mpirun: the flow solver in parallel
  libnlopt-dev           # NLopt: the diagnosis workflow's bounded fits (BOBYQA)
  libgtest-dev           # tests
  gnuplot-nox            # plots (PNG and SVG)
  python3                # scripts/chapter5_numbers.py (the reference run's comparison table)
  python3-numpy python3-scipy  # bench/foreign: the independent test bench of the diagnosis (issue 17)
  libopenblas0-pthread   # fast BLAS for the sparse direct solves of the FE stages
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# CVODE optimised, from Debian's own source of the installed version
# (scripts/cvode.sh): the same results, a fifth faster. Without it (no source
# to be had), Debian's library.
cvode=""
if cvode_out=$(bash scripts/cvode.sh build); then
  cvode=$(tail -1 <<< "$cvode_out")
else
  echo "setup: CVODE could not be built from Debian's source (above);" \
       "using Debian's library (slower, the same results)" >&2
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DRECTIFY_CVODE_LIBRARY="$cvode"
cmake --build build -j"$(nproc)"
