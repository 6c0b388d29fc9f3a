#!/usr/bin/env python3
"""Time `meshio.read(PATH)`: best of R runs (default 3), each in a fresh
Python process, and that process's peak RSS (resource.getrusage ru_maxrss).

    reference/.venv/bin/python reference/encodings/time_meshio.py bench-data/p2_tri_1000000.vtu

Prints one JSON line:
  {"file", "size_bytes", "points", "cells", "seconds_best", "seconds_all",
   "peak_rss_mb" (max over runs, whole process: interpreter + numpy + meshio + data),
   "rss_before_read_mb" (ru_maxrss after the imports, before the read),
   "meshio", "python"}
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys


def child(path):
    import resource
    import time

    import meshio

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    m = meshio.read(path)
    t1 = time.perf_counter()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    print(json.dumps({"seconds": t1 - t0, "peak_kib": peak, "before_kib": before,
                      "points": int(len(m.points)), "cells": int(sum(len(c.data) for c in m.cells)),
                      "meshio": meshio.__version__}))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("path")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.path)
        return 0
    if not os.path.isfile(args.path):
        print(f"time_meshio: {args.path}: no such file", file=sys.stderr)
        return 2
    runs = []
    for _ in range(args.repeat):
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", args.path],
                             check=True, capture_output=True, text=True)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    print(json.dumps({
        "file": args.path,
        "size_bytes": os.path.getsize(args.path),
        "points": runs[0]["points"],
        "cells": runs[0]["cells"],
        "seconds_best": min(r["seconds"] for r in runs),
        "seconds_all": [round(r["seconds"], 3) for r in runs],
        "peak_rss_mb": round(max(r["peak_kib"] for r in runs) / 1024.0, 1),
        "rss_before_read_mb": round(max(r["before_kib"] for r in runs) / 1024.0, 1),
        "meshio": runs[0]["meshio"],
        "python": platform.python_version(),
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
