#!/usr/bin/env python3
"""make_corpus.py SEEDS_DIR [--data DIR] [--sim DATASET_DIR]: the generated seed corpus of the fuzz targets.

Adds to SEEDS_DIR/<target>/ (fuzz_seeds has written the encoder-made seeds already):
  - the real files of ../shared/data (PDS3 labels and a shrunken Opportunity .IMG, the M2020 metadata JSON,
    the Spirit label excerpts, the CAHVOR oracle text) for pds3 and camera_file;
  - a simulated panorama (areomap-sim output: panorama.json, .cahvor models, truth CSVs, shortened) for
    panorama, camera_file and tiepoints.
Nothing here is committed: the corpus lives in the fuzz build folder.
"""
import argparse
import os
import re
import shutil
import sys


def put(seeds, target, name, data):
    d = os.path.join(seeds, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def compact_label(label):
    """The parts of a real label that the readers use: the top-level statements before the first GROUP or
    OBJECT (pointers, record sizes), the IMAGE object and the camera model groups, then END. A full MER label
    is ~23 KB, mostly groups nobody reads; the compact one keeps the fuzzer's inputs small and fast."""
    lines = label.splitlines(keepends=True)
    out, keep, head = [], False, True
    for line in lines:
        t = line.strip()
        if re.match(r"(GROUP|OBJECT)\s*=", t):
            head = False
            keep = bool(re.match(r"(OBJECT\s*=\s*IMAGE|GROUP\s*=\s*GEOMETRIC_CAMERA_MODEL)\s*$", t))
        if head or keep or t == "END":
            out.append(line)
        if re.match(r"END_(GROUP|OBJECT)\s*=", t):
            keep = False
    return "".join(out)


def shrink_pds3(raw):
    """A small attached-label PDS3 image from a real one: the label text with the IMAGE object set to
    8 x 8 samples and ^IMAGE pointing (in <BYTES>) just after the label, then 8 x 8 samples of the real body."""
    end = re.search(rb"\r?\nEND\r?\n", raw)
    if end is None:
        return None
    label = raw[: end.end()].decode("latin-1")
    record_bytes = int(re.search(r"RECORD_BYTES\s*=\s*(\d+)", label).group(1))
    pointer = int(re.search(r"\n\^IMAGE\s*=\s*(\d+)", label).group(1))
    bits = int(re.search(r"SAMPLE_BITS\s*=\s*(\d+)", label).group(1))
    # Only the IMAGE object's size (the first OBJECT = IMAGE ... END_OBJECT = IMAGE block).
    m = re.search(r"OBJECT\s*=\s*IMAGE\s*\r?\n(.*?)END_OBJECT\s*=\s*IMAGE", label, re.S)
    if m is None:
        return None
    block = re.sub(r"(\n\s*LINES\s*=\s*)\d+", r"\g<1>8", m.group(1))
    block = re.sub(r"(\n\s*LINE_SAMPLES\s*=\s*)\d+", r"\g<1>8", block)
    label = compact_label(label[: m.start(1)] + block + label[m.end(1) :])
    body_at = record_bytes * (pointer - 1) + 512 * record_bytes // 2  # a row from the middle of the image
    body = raw[body_at : body_at + 8 * 8 * bits // 8]
    # ^IMAGE in bytes: the label length is fixed first (the pointer is padded to 12 digits).
    label = re.sub(r"\n\^IMAGE\s*=\s*\d+", "\n^IMAGE = %012d <BYTES>" % 0, label, count=1)
    label = label.replace("%012d <BYTES>" % 0, "%012d <BYTES>" % (len(label.encode("latin-1")) + 1), 1)
    return label.encode("latin-1") + body


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seeds")
    ap.add_argument("--data", default="")
    ap.add_argument("--sim", default="")
    a = ap.parse_args()
    n = 0
    if a.data and os.path.isdir(a.data):
        for root, _, files in os.walk(a.data):
            for name in sorted(files):
                path = os.path.join(root, name)
                low = name.lower()
                if low.endswith(".img"):
                    with open(path, "rb") as f:
                        raw = f.read()
                    small = shrink_pds3(raw)
                    if small is not None:
                        put(a.seeds, "pds3", name + ".small", small)
                        put(a.seeds, "camera_file", name + ".label", small[: re.search(rb"\r?\nEND\r?\n", small).end()])
                        n += 2
                elif low.endswith(".lbl") or (low.endswith(".json") and "metadata" in low):
                    with open(path, "rb") as f:
                        raw = f.read()
                    put(a.seeds, "camera_file", name, raw)
                    n += 1
                    if low.endswith(".lbl"):
                        put(a.seeds, "pds3", name, raw)
                        n += 1
                elif low.endswith(".cahvor") or low.endswith(".cahv") or low.endswith(".cahvore") or name == "example_vectors.txt":
                    with open(path, "rb") as f:
                        put(a.seeds, "camera_file", name, f.read())
                    n += 1
    if a.sim and os.path.isdir(a.sim):
        pano = os.path.join(a.sim, "panorama.json")
        if os.path.exists(pano):
            with open(pano, "rb") as f:
                put(a.seeds, "panorama", "sim_panorama.json", f.read())
            n += 1
        for sub in ("models", os.path.join("truth", "models")):
            d = os.path.join(a.sim, sub)
            if os.path.isdir(d):
                for name in sorted(os.listdir(d))[:2]:
                    with open(os.path.join(d, name), "rb") as f:
                        put(a.seeds, "camera_file", "sim_" + sub.replace(os.sep, "_") + "_" + name, f.read())
                    n += 1
        for name in ("observations.csv", "points.csv"):
            p = os.path.join(a.sim, "truth", name)
            if os.path.exists(p):
                with open(p, "rb") as f:
                    lines = f.read().splitlines(keepends=True)[:40]
                put(a.seeds, "tiepoints", "sim_" + name, b"".join(lines))
                n += 1
    print("make_corpus: %d seeds from real data and the simulator into %s" % (n, a.seeds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
