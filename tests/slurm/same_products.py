#!/usr/bin/env python3
"""same_products.py A B: the output folders of two areomap-traverse runs hold the same products, byte for byte.

Left out: logs/ (the jobs' console output) and each site's manifest.json (it holds the checksum of the site's
report.json); the sites' report.json and report.html are compared without their stage times ("seconds", the
"Stage timings" table: they differ from run to run). Prints the first difference and exits 1, else the number
of files compared.
"""
import json
import os
import re
import sys


def files(root):
    out = set()
    for d, _, names in os.walk(root):
        for n in names:
            rel = os.path.relpath(os.path.join(d, n), root)
            if rel.startswith("logs" + os.sep) or os.path.basename(rel) == "manifest.json":
                continue
            out.add(rel)
    return out


def without_times(value):
    if isinstance(value, dict):
        return {k: without_times(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [without_times(v) for v in value]
    return value


def content(path, rel):
    data = open(path, "rb").read()
    if rel.startswith("sites" + os.sep) and rel.endswith("report.json"):
        return json.dumps(without_times(json.loads(data)), sort_keys=True).encode()
    if rel.startswith("sites" + os.sep) and rel.endswith("report.html"):
        return re.sub(rb"Stage timings.*?</table>", b"", data, flags=re.S)
    return data


def main():
    a, b = sys.argv[1], sys.argv[2]
    fa, fb = files(a), files(b)
    if fa != fb:
        print("differ: files only in %s: %s; only in %s: %s" % (a, sorted(fa - fb)[:5], b, sorted(fb - fa)[:5]))
        return 1
    for rel in sorted(fa):
        if content(os.path.join(a, rel), rel) != content(os.path.join(b, rel), rel):
            print("differ: %s (%s vs %s)" % (rel, a, b))
            return 1
    print("same: %d product files (%s = %s)" % (len(fa), a, b))
    return 0 if fa else 1


sys.exit(main())
