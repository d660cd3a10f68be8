#!/usr/bin/env bash
# Builds CVODE from Debian's own source package, optimised, for the system
# model (docs/benchmarks.md, "CVODE built here"). Debian's libsundials_cvode
# is compiled without optimisation (its rules set CMAKE_C_FLAGS to -fcommon
# alone), which costs about a fifth of every model run. This fetches the
# source of the very version installed (libsundials-dev), through a private
# apt source list (the system's own is not touched), and builds the CVODE
# library alone at -O2 with -ffp-contract=off: the same C code, rounded as
# Debian's build rounds it (tests: Install.TheCvodeBuiltHereRunsAsDebiansBitForBit).
#   scripts/cvode.sh BUILD_DIR   -> BUILD_DIR/_deps/cvode/lib/libsundials_cvode.so
# Prints the library's path on its last line; exits non-zero (and leaves
# nothing half-made) when the source cannot be had: rectify then links
# Debian's library, slower and with the same results.
set -euo pipefail
build=$(realpath -m "${1:?usage: scripts/cvode.sh BUILD_DIR}")
prefix="$build/_deps/cvode"
version=$(dpkg-query -W -f='${source:Version}' libsundials-dev)
lib="$prefix/lib/libsundials_cvode.so"
if [ -f "$prefix/VERSION" ] && [ "$(cat "$prefix/VERSION")" = "$version" ] && [ -f "$lib" ]; then
  echo "$lib"
  exit 0
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/rectify-cvode.XXXXXX")
trap 'rm -rf "$work"' EXIT
echo "cvode: fetching Debian's source of sundials $version" >&2

# The system's Debian sources, as source entries, in a list of our own.
mkdir -p "$work/parts" "$work/lists/partial" "$work/src"
shopt -s nullglob
for f in /etc/apt/sources.list.d/*.sources; do
  grep -q 'debian' "$f" || continue
  sed 's/^Types:.*/Types: deb-src/' "$f" > "$work/parts/$(basename "$f")"
done
for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
  [ -f "$f" ] || continue
  grep -E '^deb[[:space:]].*debian' "$f" | sed 's/^deb[[:space:]]/deb-src /' >> "$work/parts/from-lists.list" || true
done
mkdir -p "$work/cache/archives/partial"
apt_private=(-o Dir::Etc::SourceList=/dev/null -o Dir::Etc::SourceParts="$work/parts"
             -o Dir::State::Lists="$work/lists" -o Dir::Cache="$work/cache" -o APT::Sandbox::User=root)
apt-get "${apt_private[@]}" -qq update >&2
(cd "$work/src" && apt-get "${apt_private[@]}" -qq source "sundials=$version" >&2)
source_dir=$(find "$work/src" -mindepth 1 -maxdepth 1 -type d -name 'sundials-*' | head -1)
[ -n "$source_dir" ] || { echo "cvode: no source tree unpacked" >&2; exit 1; }

# CVODE alone, shared, as Debian configures it but for the optimisation.
cmake -S "$source_dir" -B "$work/build" -DCMAKE_BUILD_TYPE=None \
  -DCMAKE_C_FLAGS="-O2 -fcommon -ffp-contract=off" \
  -DBUILD_SHARED_LIBS=ON -DBUILD_STATIC_LIBS=OFF -DBUILD_CVODE=ON \
  -DBUILD_ARKODE=OFF -DBUILD_CVODES=OFF -DBUILD_IDA=OFF -DBUILD_IDAS=OFF -DBUILD_KINSOL=OFF \
  -DEXAMPLES_ENABLE_C=OFF -DEXAMPLES_ENABLE_CXX=OFF -DEXAMPLES_INSTALL=OFF -DENABLE_MPI=OFF > "$work/configure.log" 2>&1 ||
  { cat "$work/configure.log" >&2; exit 1; }
cmake --build "$work/build" --target sundials_cvode_shared -j"$(nproc)" > "$work/build.log" 2>&1 ||
  { tail -30 "$work/build.log" >&2; exit 1; }

# Into place whole: a folder made aside, then renamed.
rm -rf "$prefix.new"
mkdir -p "$prefix.new/lib"
cp -P "$work"/build/src/cvode/libsundials_cvode.so* "$prefix.new/lib/"
echo "$version" > "$prefix.new/VERSION"
rm -rf "$prefix"
mv "$prefix.new" "$prefix"
echo "cvode: built $lib (sundials $version, -O2)" >&2
echo "$lib"
