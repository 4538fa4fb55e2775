#!/usr/bin/env python3
"""compare_hil.py NATIVE_PRODUCTS HIL_PRODUCTS PAIRS: the HIL run's products against the all-native run's
(tests/hil/run.sh); of a traverse, every site's (PAIRS each) and the rover's own site poses (rover_poses.csv
within the golden EO tolerance, a pose for every site). Checks per panorama: both streams complete (PAIRS pairs, no gaps, duplicates or rejections), the
rover's final EO arrived with 0 heap allocations after start-up on both (native and under qemu); rover_tiepoints.csv identical; the rover's
adjusted models (rover_models/*.cahvor) and the ground's products derived from the stream (models/, eo.csv,
tiepoints.csv) equal within the golden EO tolerance (tests/golden/compare_golden.py: 1e-9 relative; the
reason: libm differs between targets); the image products made. Prints the rover's per-stage seconds per
pair of both runs and their ratio. Exit 0 equal, 1 different."""
import glob
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "golden"))
from compare_golden import EO_TOL, SIGMA_TOL, rel  # noqa: E402


def tokens(path):
    out = []
    with open(path) as f:
        for line in f:
            for t in line.replace(",", " ").split():
                try:
                    out.append(float(t))
                except ValueError:
                    out.append(t)
    return out


def compare_numbers(a_path, b_path, tol):
    """(max relative difference, first problem or None) of two text files equal up to their numbers."""
    a, b = tokens(a_path), tokens(b_path)
    if len(a) != len(b):
        return float("inf"), "%s: %d vs %d tokens" % (os.path.basename(a_path), len(a), len(b))
    worst = 0.0
    for x, y in zip(a, b):
        if isinstance(x, float) and isinstance(y, float):
            worst = max(worst, rel(x, y))
        elif x != y:
            return float("inf"), "%s: '%s' vs '%s'" % (os.path.basename(a_path), x, y)
    return worst, ("%s differs by %.3g relative (> %g)" % (os.path.basename(a_path), worst, tol) if worst > tol else None)


def main():
    native, hil, pairs = sys.argv[1], sys.argv[2], int(sys.argv[3])
    sites_dir = os.path.join(native, "sites")
    if not os.path.isdir(sites_dir):
        return 1 if compare_products(native, hil, pairs, "") else 0
    # A traverse: every site's products as a panorama's, and the rover's own site poses.
    problems, site_problems = [], []
    sites = sorted(os.listdir(sites_dir))
    for site in sites:
        site_problems += compare_products(os.path.join(native, "sites", site), os.path.join(hil, "sites", site), pairs,
                                     site + ": ")
    for name, d in (("native", native), ("hil", hil)):
        rp = json.load(open(os.path.join(d, "report.json"))).get("rover_poses") or {}
        if rp.get("sites") != len(sites):
            problems.append("%s: the rover published poses of %s of %d sites (missing %s)" % (
                name, rp.get("sites"), len(sites), rp.get("missing")))
    a, b = os.path.join(native, "rover_poses.csv"), os.path.join(hil, "rover_poses.csv")
    if not (os.path.isfile(a) and os.path.isfile(b)):
        problems.append("no rover_poses.csv in both runs")
    else:
        worst, p = compare_numbers(a, b, EO_TOL)
        print("hil: rover_poses.csv: %s, max relative difference %.3g" % (
            "byte-identical" if open(a, "rb").read() == open(b, "rb").read() else "not byte-identical", worst))
        if p:
            problems.append(p)
    for p in problems:
        print("hil: " + p, file=sys.stderr)
    return 1 if problems or site_problems else 0


def compare_products(native, hil, pairs, site):
    """The problems (printed) of one panorama's products, HIL against native."""
    problems = []
    reports = {}
    for name, d in (("native", native), ("hil", hil)):
        r = json.load(open(os.path.join(d, "report.json")))
        reports[name] = r
        s, rv = r.get("stream", {}), r.get("rover", {})
        if s.get("pairs") != pairs or s.get("gaps") or s.get("duplicates") or s.get("rejected"):
            problems.append("%s: stream %s (expected %d clean pairs)" % (name, json.dumps(s, sort_keys=True), pairs))
        if rv.get("eo_is_final") is not True:
            problems.append("%s: the rover's final EO did not arrive" % name)
        # Zero heap after start-up on every target: the pipeline thread's count (the 3 allocations once seen
        # under qemu-aarch64 were libjpeg-turbo's per-thread SIMD detection, now done at the thread's start-up;
        # AREOMAP_HEAP_TRACE=1 prints the stacks of any new one, toolchains/README.md).
        if rv.get("heap_allocs_after_init") != 0:
            problems.append("%s: rover heap allocations after start-up %s (run the rover with AREOMAP_HEAP_TRACE=1 "
                            "for their call stacks)" % (name, rv.get("heap_allocs_after_init")))
        for f in ("dem.tif", "dem_sigma.tif", "ortho.tif", "points.ply", "report.html", "eo.csv", "tiepoints.csv"):
            if not os.path.isfile(os.path.join(d, f)):
                problems.append("%s: no %s" % (name, f))
    with open(os.path.join(native, "rover_tiepoints.csv")) as a, open(os.path.join(hil, "rover_tiepoints.csv")) as b:
        ties_native, ties_hil = a.read(), b.read()
    if ties_native != ties_hil:
        problems.append("rover_tiepoints.csv differs")
    figures = {}
    for label, pattern, tol in (("rover_models", "rover_models/*.cahvor", EO_TOL), ("models", "models/*.cahvor", EO_TOL),
                                ("eo.csv", "eo.csv", SIGMA_TOL), ("tiepoints.csv", "tiepoints.csv", EO_TOL)):
        files = sorted(glob.glob(os.path.join(native, pattern)))
        if not files:
            problems.append("native: no %s" % pattern)
        worst, identical = 0.0, 0
        for f in files:
            g = os.path.join(hil, os.path.relpath(f, native))
            if not os.path.isfile(g):
                problems.append("hil: no %s" % os.path.relpath(f, native))
                continue
            identical += open(f, "rb").read() == open(g, "rb").read()
            w, p = compare_numbers(f, g, tol)
            worst = max(worst, w)
            if p:
                problems.append(p)
        figures[label] = "%d/%d files byte-identical, max relative difference %.3g" % (identical, len(files), worst)
    print("hil: %srover tie observations %d lines, %s" % (site, ties_native.count("\n") - 1, "identical" if ties_native == ties_hil else "DIFFERENT"))
    for k, v in figures.items():
        print("hil: %s%s: %s" % (site, k, v))
    sn = reports["native"].get("rover", {}).get("stage_seconds_per_pair", {})
    sh = reports["hil"].get("rover", {}).get("stage_seconds_per_pair", {})
    print("hil: %srover seconds per pair native -> qemu-aarch64: " % site + ", ".join(
        "%s %.3f -> %.3f (%.0fx)" % (k, sn[k], sh.get(k, 0), sh.get(k, 0) / sn[k]) for k in sn if sn[k]))
    problems = [site + p for p in problems]
    for p in problems:
        print("hil: " + p, file=sys.stderr)
    return problems


if __name__ == "__main__":
    sys.exit(main())
