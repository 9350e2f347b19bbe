#!/usr/bin/env python3
"""Byte-compare two vkmech output trees, ignoring what legitimately varies run
to run (wall-clock timings, dates, paths of temporary directories).

    compare-outputs.py OLD_DIR NEW_DIR

EXR files: every channel's pixel values must be bit-identical (the header
holds timings). PNG/CSV/Markdown tables and other files: bytes identical,
except files made of measured times (the cost and time tables and figures) and report.md (its header has the wall time). JSON:
identical after removing keys whose name mentions seconds, time, date or
paths/s. Exit 0 when identical, 1 otherwise (each difference listed).
"""
import json
import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "analysis", "validation"))


VARYING_KEY = re.compile(r"second|time|date|paths_per|_ms$|pipeline_cache|command", re.I)
VARYING_FILE = re.compile(r"(alloc_time|equal_time|error_vs_time|cost_by_bucket\w*)\.|/cache/|report\.md$|\.manifest\.json$")


def strip(o):
    if isinstance(o, dict):
        return {k: strip(v) for k, v in o.items() if not VARYING_KEY.search(k)}
    if isinstance(o, list):
        return [strip(v) for v in o]
    return o


def same(a, b):
    if a.endswith(".exr"):
        # Only EXRs need numpy (a study's outputs have none, so the scale-out test runs without it).
        import numpy as np
        from exr import read_exr
        x, y = read_exr(a), read_exr(b)
        if sorted(x) != sorted(y):
            return "channel lists differ"
        bad = [c for c in x if not np.array_equal(x[c].view(np.uint64), y[c].view(np.uint64))]
        return f"channels differ: {bad}" if bad else None
    if a.endswith(".json"):
        return None if strip(json.load(open(a))) == strip(json.load(open(b))) else "JSON differs (timings removed)"
    return None if open(a, "rb").read() == open(b, "rb").read() else "bytes differ"


def main(old, new):
    problems, compared, skipped = [], 0, 0
    for root, _, names in os.walk(old):
        for n in sorted(names):
            a = os.path.join(root, n)
            rel = os.path.relpath(a, old)
            b = os.path.join(new, rel)
            if VARYING_FILE.search("/" + rel):
                skipped += 1
                continue
            if not os.path.exists(b):
                problems.append(f"{rel}: missing in {new}")
                continue
            why = same(a, b)
            compared += 1
            if why:
                problems.append(f"{rel}: {why}")
    for p in problems:
        print("differs: " + p)
    print(f"{compared} files compared, {skipped} skipped (timings, cache, manifests), {len(problems)} differ")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
