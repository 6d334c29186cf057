#!/usr/bin/env bash
# Builds SUNDIALS 6.4.1's CVODE with optimisation into PREFIX, for a faster vadsim.
#
# Why: Debian bookworm's libsundials-dev 6.4.1+dfsg1-3 is compiled without optimisation (its
# debian/rules passes -DCMAKE_C_FLAGS=-fcommon, which replaces dpkg's "-g -O2"; objdump shows
# -O0 code). Half of a vadsim run's instructions are in CVODE's own code, so the same source
# built with -O2 makes a 400-cycle run about 1.5x faster with bit-identical results
# (docs/cli.md, "Benchmarks"). vadsim keeps Debian's package as its default; this is opt-in.
#
# usage: bench/build_sundials.sh PREFIX [SOURCE]
#   SOURCE: a sundials-6.4.x source folder or tarball; without it, Debian's own source package
#   is fetched with `apt-get source sundials` (needs a deb-src line in the apt sources).
# then:  pip install . -C cmake.define.SUNDIALS_DIR=PREFIX/lib/cmake/sundials
#        (the extension records PREFIX/lib as its run path, so it loads this CVODE, not Debian's)
set -euo pipefail
if [ $# -lt 1 ] || [ $# -gt 2 ]; then
  sed -n 2,16p "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
prefix=$(realpath -m "$1")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ $# -eq 2 ]; then
  src=$(realpath "$2")
  if [ -f "$src" ]; then
    tar -xf "$src" -C "$work"
    src=$(find "$work" -maxdepth 1 -mindepth 1 -type d -name 'sundials-*' | head -n1)
  fi
else
  if ! (cd "$work" && apt-get source -qq --download-only sundials >/dev/null 2>&1); then
    echo "build_sundials: 'apt-get source sundials' failed: add a deb-src line for bookworm" \
         "to the apt sources, or pass a sundials-6.4.x source folder or tarball" >&2
    exit 1
  fi
  tar -xf "$work"/sundials_*.orig.tar.* -C "$work"
  src=$(find "$work" -maxdepth 1 -mindepth 1 -type d -name 'sundials-*' | head -n1)
fi
if [ -z "${src:-}" ] || [ ! -f "$src/CMakeLists.txt" ]; then
  echo "build_sundials: no SUNDIALS source found in ${2:-the Debian source package}" >&2
  exit 1
fi
echo "build_sundials: $src -> $prefix (CVODE, Release)"
cmake -S "$src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_INSTALL_LIBDIR=lib \
  -DBUILD_ARKODE=OFF -DBUILD_CVODES=OFF -DBUILD_IDA=OFF -DBUILD_IDAS=OFF -DBUILD_KINSOL=OFF \
  -DBUILD_STATIC_LIBS=OFF -DEXAMPLES_ENABLE_C=OFF -DEXAMPLES_INSTALL=OFF >/dev/null
cmake --build "$work/build" --parallel "$(nproc)" >/dev/null
cmake --install "$work/build" >"$work/install.log" 2>&1 || { cat "$work/install.log" >&2; exit 1; }
echo "build_sundials: done; now: pip install . -C cmake.define.SUNDIALS_DIR=$prefix/lib/cmake/sundials"
