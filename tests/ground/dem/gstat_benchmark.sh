#!/bin/sh
# Kriging 1e4 and 1e5 points onto 1000 x 1000 cells: areomap (ground/dem krigeDem) against R's gstat
# (ordinary kriging, the same variogram model, fitted by areomap, and the same neighbourhood size k = 16),
# time and RMSE against the synthetic truth, in one run. Needs Debian's r-base-core and r-cran-gstat
# (not installed by setup.sh: `apt-get install r-base-core r-cran-gstat`).
# Usage: tests/ground/dem/gstat_benchmark.sh [BUILD_DIR] [--quick]   (--quick: 500 x 500 cells)
set -eu
build=${1:-build}
quick=${2:-}
here=$(cd "$(dirname "$0")" && pwd)
command -v Rscript >/dev/null || { echo "gstat_benchmark: Rscript missing (apt-get install r-base-core r-cran-gstat)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$build/tests/ground_products_bench" --kriging-only --export "$work" $quick
echo
echo "| points | cells | k | model | gstat time | areomap time | gstat / areomap | areomap time, 1 thread | gstat / areomap 1 thread | gstat RMSE | areomap RMSE |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for n in 10000 100000; do
  Rscript "$here/gstat_kriging.R" "$work/points_$n"
done
