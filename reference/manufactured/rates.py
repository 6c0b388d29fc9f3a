#!/usr/bin/env python3
"""Convergence table of the manufactured problems (n = 4 ... 64; nothing written to fixtures/).

    reference/.venv/bin/python reference/manufactured/rates.py [--nmax 64] [--no-readme]

Every level is written to a temporary folder exactly like a fixture and evaluated from the file.
"""
import argparse
import math
import re
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))
sys.path.insert(0, str(HERE))
import make as MK  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nmax", type=int, default=64)
    ap.add_argument("--no-readme", action="store_true")
    a = ap.parse_args()
    levels = [n for n in (4, 8, 16, 32, 64, 128) if n <= a.nmax]
    lines = ["| problem | P | n | dofs | ‖u−u_h‖_L2 | rate | energy error | rate | ‖σ−σ_h,file‖_L2 | rate | "
             "contact force (exact 1.5) | active x-range | stick x-range | time s |", "|" + "---|" * 14]
    t_all = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for fr in (0.0, 0.4):
            for deg in (1, 2):
                prev = None
                for n in levels:
                    name = MK.case_name(fr, deg, n)
                    MK.CASES.setdefault(name, dict(friction=fr, degree=deg, n=n))
                    t0 = time.time()
                    exp = MK.make_one(name, tmp, {})
                    dt = time.time() - t0
                    er = exp["errors"]["fe"]
                    c = exp["boundaries"]["bottom"]
                    cur = (er["u_L2"], er["energy"], er["stress_file_L2"])
                    rates = ["" if prev is None else f"{math.log(p / q_, 2):.2f}" for p, q_ in zip(prev or cur, cur)]
                    prev = cur
                    st = c.get("stick_x_range")
                    lines.append(f"| {'Coulomb 0.4' if fr else 'frictionless'} | {deg} | {n} | {exp['solver']['dofs']} | "
                                 f"{cur[0]:.3e} | {rates[0]} | {cur[1]:.3e} | {rates[1]} | {cur[2]:.3e} | {rates[2]} | "
                                 f"{c['normal_force']:.5f} | [{c['active_x_range'][0]:.4f}, {c['active_x_range'][1]:.4f}] | "
                                 + (f"[{st[0]:.4f}, {st[1]:.4f}]" if st else "–") + f" | {dt:.1f} |")
                    print(lines[-1], flush=True)
    print(f"total {time.time() - t_all:.0f} s")
    if not a.no_readme:
        rd = HERE / "README.md"
        text = rd.read_text()
        text = re.sub(r"(<!-- rates:begin -->\n).*?(<!-- rates:end -->)", lambda m: m.group(1) + "\n".join(lines) + "\n" + m.group(2),
                      text, flags=re.S)
        rd.write_text(text)


if __name__ == "__main__":
    main()
