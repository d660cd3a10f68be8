#!/usr/bin/env bash
# Builds the Debian package (CPack) from build/: build/rectify_<version>_<arch>.deb.
# Its dependencies are Debian's own packages (found by dpkg-shlibdeps from the
# shared libraries the tool links, plus gnuplot-nox and openmpi-bin), so on a
# Debian 12 machine:   apt-get install ./build/rectify_*.deb
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cd build
cpack -G DEB
ls -l rectify_*.deb
dpkg-deb --info rectify_*.deb | sed -n '/Depends/p'
