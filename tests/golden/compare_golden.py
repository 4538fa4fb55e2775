#!/usr/bin/env python3
"""Compares two golden_rover outputs (tests/golden/GoldenRover.cpp): the tie-point observations must be
identical lists (pair, point id, image, kind, sample, line: every bit), the final EO equal within a
tolerance, the final solution's sweeps and stop rule equal, and the pipeline's heap allocations after start-up
0 in both (`heap,ACTIVE,COUNT`; the candidate, a target build, must have counted them: ACTIVE 1).

Tolerance and its reason (toolchains/README.md, "Same answers"): every build uses -ffp-contract=off, so the
project's own arithmetic is the same IEEE sequence on every target, but glibc's libm is not: x86-64 picks
FMA variants of sin/cos/atan2/asin/exp/log/pow at run time, aarch64 and PowerPC have their own, and a last-bit
difference there propagates through the iterative adjustment. EO centres and angles must agree to 1e-9
relative (|a-b| <= 1e-9 * max(1, |a|)); standard deviations, rms and sigma0 to 1e-6 relative (they come from
an inverse of the normal matrix and carry its condition number). Prints the largest differences found.
Exit 0 equal, 1 different."""
import argparse
import sys

EO_TOL = 1e-9
SIGMA_TOL = 1e-6
TIE_TOL_PX = 1e-9


def read(path):
    ties, eo, final, heap = [], {}, None, None
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            p = line.rstrip("\n").split(",")
            if p[0] == "tie":
                ties.append((int(p[1]), int(p[2]), p[3], int(p[4]), float.fromhex(p[5]), float.fromhex(p[6])))
            elif p[0] == "eo":
                eo[p[1]] = [float.fromhex(v) for v in p[4:]]
            elif p[0] == "heap":
                heap = (int(p[1]), int(p[2]))
            elif p[0] == "final":
                if final is not None:
                    raise SystemExit("%s: more than one final EO" % path)
                final = (int(p[1]), int(p[2]), int(p[3]), float.fromhex(p[4]), float.fromhex(p[5]))
    if final is None:
        raise SystemExit("%s: no final EO" % path)
    if heap is None:
        raise SystemExit("%s: no heap line (golden_rover from before the heap count?)" % path)
    return ties, eo, final, heap


def rel(a, b):
    return abs(a - b) / max(1.0, abs(a), abs(b))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("reference")
    ap.add_argument("candidate")
    ap.add_argument("--label", default="golden")
    a = ap.parse_args()
    rt, reo, rf, rh = read(a.reference)
    ct, ceo, cf, ch = read(a.candidate)
    problems = []
    # The pipeline after start-up makes no heap allocation (RoverNode.hpp), on the target too.
    if ch[0] != 1:
        problems.append("the candidate did not count its heap allocations (no heap counter)")
    for name, (active, count) in (("reference", rh), ("candidate", ch)):
        if active and count != 0:
            problems.append("%s: %d heap allocations after start-up (expected 0)" % (name, count))
    # The list (pair, point id, image, kind, in order) must be identical; intra-pair positions every bit;
    # inter-pair positions (located through the CAHVOR projection of the coarse DEM: libm) within TIE_TOL_PX.
    first = next((i for i, (x, y) in enumerate(zip(rt, ct)) if x[:4] != y[:4] or
                  (x[3] == 1 and x[4:] != y[4:]) or max(abs(x[4] - y[4]), abs(x[5] - y[5])) > TIE_TOL_PX), None)
    if len(rt) != len(ct) or first is not None:
        first = min(len(rt), len(ct)) if first is None else first
        problems.append("tie points differ: %d vs %d observations, first difference at #%d: %s vs %s" % (
            len(rt), len(ct), first, rt[first] if first < len(rt) else "-", ct[first] if first < len(ct) else "-"))
    tie_px = max([max(abs(x[4] - y[4]), abs(x[5] - y[5])) for x, y in zip(rt, ct)] or [0.0])
    tie_bits = sum(x == y for x, y in zip(rt, ct))
    if sorted(reo) != sorted(ceo):
        problems.append("EO images differ: %s vs %s" % (sorted(reo), sorted(ceo)))
    max_eo = [0.0, ""]
    max_sigma = [0.0, ""]
    identical = 0
    for stem in sorted(set(reo) & set(ceo)):
        r, c = reo[stem], ceo[stem]
        if r == c:
            identical += 1
        for i, (x, y) in enumerate(zip(r, c)):
            d = rel(x, y)
            slot = max_eo if i < 6 else max_sigma
            if d > slot[0]:
                slot[0], slot[1] = d, "%s field %d: %r vs %r" % (stem, i, x, y)
    if max_eo[0] > EO_TOL:
        problems.append("EO differs by %.3g relative (> %g): %s" % (max_eo[0], EO_TOL, max_eo[1]))
    if max_sigma[0] > SIGMA_TOL:
        problems.append("EO sigmas differ by %.3g relative (> %g): %s" % (max_sigma[0], SIGMA_TOL, max_sigma[1]))
    if (rf[0], rf[2]) != (cf[0], cf[2]):
        problems.append("final solution: sweeps/stop rule %s vs %s" % ((rf[0], rf[2]), (cf[0], cf[2])))
    fin = max(rel(rf[3], cf[3]), rel(rf[4], cf[4]))
    if fin > SIGMA_TOL:
        problems.append("rms/sigma0 differ by %.3g relative" % fin)
    print("%s: tie observations %d vs %d (%s; %d bit-identical, max position difference %.3g px); EO of %d images, %d bit-identical, max relative difference %.3g "
          "(centre/angles, tolerance %g), %.3g (sigmas, tolerance %g); sweeps %d vs %d, iterations %d vs %d, "
          "rms %.17g vs %.17g; heap allocations after start-up %s vs %s" % (
              a.label, len(rt), len(ct), "identical" if rt == ct else "list identical" if not problems or
              not problems[0].startswith("tie") else "DIFFERENT", tie_bits, tie_px, len(reo), identical,
              max_eo[0], EO_TOL, max_sigma[0], SIGMA_TOL, rf[0], cf[0], rf[1], cf[1], rf[3], cf[3],
              rh[1] if rh[0] else "not counted", ch[1] if ch[0] else "not counted"))
    if not rt:
        problems.append("no tie points at all (the input gives the matcher nothing to compare)")
    for p in problems:
        print("%s: %s" % (a.label, p), file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
