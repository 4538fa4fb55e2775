#!/usr/bin/env bash
# areomap set-up: installs every Debian package the project needs (idempotent: apt runs only when something
# is missing) and configures and builds into build/ (tools in build/bin/).
#
#   ./setup.sh                      native build (Release)
#   ./setup.sh --targets aarch64,powerpc   also the cross targets, built into build-<target>/
#                                          (toolchains/README.md)
#   ./setup.sh --no-build           packages only
#   ./setup.sh --fuzz               also clang and libFuzzer for the fuzz targets (tests/fuzz/run.sh)
#   ./setup.sh --no-benchmarks      the native build without the benchmark programs (CI: no test runs them)
#   ./setup.sh --unity              the native build as a unity build: a target's files compiled a few at a
#                                   time (CI, whose binaries are only run, never shipped;
#                                   cmake/AreomapUnity.cmake); without it one file per translation unit
set -euo pipefail
cd "$(dirname "$0")"

usage() {
  sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'
}

targets=""
build=1
fuzz=0
benchmarks=ON
unity=OFF
while [ $# -gt 0 ]; do
  case "$1" in
    --targets) targets="${2:-}"; shift 2 ;;
    --targets=*) targets="${1#--targets=}"; shift ;;
    --no-build) build=0; shift ;;
    --fuzz) fuzz=1; shift ;;
    --no-benchmarks) benchmarks=OFF; shift ;;
    --unity) unity=ON; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "setup.sh: unknown option '$1'" >&2; usage >&2; exit 2 ;;
  esac
done

# The packages of the native build, its tests and the main job.
packages=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libeigen3-dev liblcm-dev liblcm-bin libturbojpeg0-dev libjpeg62-turbo-dev
  libcpputest-dev cpputest libopencv-dev libgdal-dev gdal-bin libceres-dev nlohmann-json3-dev
  libpng-dev iproute2 util-linux procps python3 time
  chromium  # tests/ground/products ReportHtmlTest: report.html rendered in headless Chromium
  libmrcal-dev  # tests/ground/io/mrcal: our CAHVOR/CAHVORE projection against mrcal's
  slurm-wlm munge  # tests/slurm: areomap-traverse --executor slurm on a one-node cluster (cluster.sh)
)

# --fuzz: Debian bookworm's clang 14 with its runtime (libFuzzer, ASan, UBSan: libclang-rt-14-dev) and llvm
# (llvm-symbolizer for the stack traces of a crash).
if [ "$fuzz" = 1 ]; then
  packages+=(clang libclang-rt-14-dev llvm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

as_root=()
if [ "$(id -u)" != 0 ]; then as_root=(sudo); fi

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  "${as_root[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup: all ${#packages[@]} Debian packages present"
fi

if [ -n "$targets" ]; then
  if [ -x toolchains/setup-targets.sh ]; then
    toolchains/setup-targets.sh "$targets"
  else
    echo "setup: cross targets ($targets) are not available yet (toolchains/setup-targets.sh missing)" >&2
    exit 1
  fi
fi

if [ "$build" = 1 ]; then
  jobs=$(nproc 2>/dev/null || echo 2)
  # AREOMAP_BUILD_BENCHMARKS and CMAKE_UNITY_BUILD are passed every time: a build folder configured once
  # without the benchmarks gets them back, one configured once as a unity build is one file per unit again.
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DAREOMAP_BUILD_BENCHMARKS=$benchmarks \
    -DCMAKE_UNITY_BUILD=$unity
  cmake --build build -j "$jobs"
  echo "setup: built into build/ (tools in build/bin/)"
  # The cross targets: the rover side and its tests (CMakePresets.json; run them with ctest --preset T).
  if [ -n "$targets" ]; then
    IFS=',' read -r -a _targets <<<"$targets"
    for t in "${_targets[@]}"; do
      case "$t" in arm64) t=aarch64 ;; ppc) t=powerpc ;; "") continue ;; esac
      cmake --preset "$t"
      cmake --build --preset "$t"
      echo "setup: built the $t target into build-$t/ (tests: ctest --preset $t)"
    done
  fi
fi
