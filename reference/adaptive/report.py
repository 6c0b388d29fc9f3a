#!/usr/bin/env python3
"""Tables of docs/adaptive.md from docs/adaptive/summary.json (between the `adaptive-tables` markers).

    reference/.venv/bin/python reference/adaptive/report.py [docs/adaptive]   # also called by run.py
"""
import json
import sys
from pathlib import Path

BEGIN, END = "<!-- adaptive-tables:begin -->", "<!-- adaptive-tables:end -->"


def _f(v, fmt="{:.2f}"):
    return "–" if v is None else fmt.format(v)


def tables(summary):
    C = summary["cases"]
    out = []
    out.append("### Fitted rates of F^½ in the number of degrees of freedom\n")
    out.append("Least-squares slope −d log F^½ / d log DOFs over all steps (in brackets: over the second half of the "
               "steps). Optimal for P2 is 1 (h²); `gap` = adaptive − uniform (all steps). Error rates: the same fit "
               "for ‖u_ref − u_h‖_E.\n")
    out.append("| case | adaptive F^½ | uniform F^½ | gap | adaptive error | uniform error | adaptive: steps, final DOFs, F^½ | uniform: steps, final DOFs, F^½ |")
    out.append("|---|---|---|---|---|---|---|---|")
    for n, r in C.items():
        ra, ru = r["rates_adaptive"], r["rates_uniform"]
        A, U = r["adaptive"][-1], r["uniform"][-1]
        gap = ra["eta_all"] - ru["eta_all"] if ra["eta_all"] is not None and ru["eta_all"] is not None else None
        out.append(f"| {n} | {_f(ra['eta_all'])} ({_f(ra['eta_second_half'])}) | {_f(ru['eta_all'])} "
                   f"({_f(ru['eta_second_half'])}) | **{_f(gap, '{:+.2f}')}** | {_f(ra['error_all'])} "
                   f"({_f(ra['error_second_half'])}) | {_f(ru['error_all'])} ({_f(ru['error_second_half'])}) | "
                   f"{len(r['adaptive']) - 1}, {A['dofs']}, {A['eta']:.3e} | {len(r['uniform']) - 1}, {U['dofs']}, {U['eta']:.3e} |")
    out.append("\n### Efficiency index F^½ / ‖u_ref − u_h‖_E per refinement step\n")
    out.append("`band` = max/min over all steps (in brackets: without step 0, the 90- / 70-triangle start mesh). "
               "Reference: see 'Efficiency index' above.\n")
    out.append("| case | refinement | per step 0, 1, 2, … | min | max | band | band w/o step 0 |")
    out.append("|---|---|---|---|---|---|---|")
    for n, r in C.items():
        for mode in ("adaptive", "uniform"):
            e = [s["efficiency"] for s in r[mode]]
            e1 = e[1:] if len(e) > 1 else e
            out.append(f"| {n} | {mode} | {', '.join(f'{v:.2f}' for v in e)} | {min(e):.2f} | {max(e):.2f} | "
                       f"{max(e) / min(e):.2f} | {max(e1) / min(e1):.2f} |")
    out.append("\n### Reference solutions\n")
    out.append("| case | cells | DOFs | F^½ of the reference (fosls) | F^½ finest adaptive | ‖u_ref‖_E | P (top reaction) | time s |")
    out.append("|---|---|---|---|---|---|---|---|")
    for n, r in C.items():
        R = r["reference"]
        out.append(f"| {n} | {R['cells']} | {R['dofs']} | {R['eta']:.3e} | {r['adaptive'][-1]['eta']:.3e} | "
                   f"{R['energy_norm']:.4f} | {R['P']:.4f} | {R['time_s']:.0f} |")
    out.append("\n### Where the adaptive loop marks\n")
    out.append("Share (by count) of the marked triangles whose centroid lies in a region, per adaptive step, and "
               "the region's share of the domain area (`area share`, geometric, mean over steps ≥ 3; `ratio` = marked share / area share) for comparison. Hertz: "
               "`within_2a` = disc of radius 2a around the contact centre (0, 0) (a = Hertz half-width from the "
               "solver's top reaction); `near_contact_ends` / `near_stick_slip` = discs of radius a/4 around the "
               "contact ends / the stick–slip transitions of that step's solution; `near_top_corners` = radius 0.1 "
               "around (±1, 1). Block: radius 0.1 around the bottom corners (the contact ends) and the top corners.\n")
    out.append("| case | region | marked share per adaptive step 0, 1, 2, … | mean over steps ≥ 3 | area share | ratio |")
    out.append("|---|---|---|---|---|---|")
    for n, r in C.items():
        keys = [k for k in r["adaptive"][0]["marked_shares"] if not k.startswith("area_")]
        for k in keys:
            v = [s["marked_shares"][k] for s in r["adaptive"]]
            ar = [s["marked_shares"]["area_" + k] for s in r["adaptive"]][3:]
            tail = v[3:] or v
            m, A = sum(tail) / len(tail), sum(ar) / max(len(ar), 1)
            out.append(f"| {n} | {k} | {', '.join(f'{x:.2f}' for x in v)} | **{m:.2f}** | {A:.4f} | "
                       f"{(m / A if A > 0 else float('nan')):.0f} |")
    out.append("\n### Contact zone of the finest adaptive solutions\n")
    out.append("| case | DOFs | P | Hertz a | transitions (x: left state → right state; 0 no contact, 1 stick, 2 slip) |")
    out.append("|---|---|---|---|---|")
    for n, r in C.items():
        A = r["adaptive"][-1]
        tr = "; ".join(f"{t['x']:+.4f}: {t['left']}→{t['right']}" for t in A["transitions"])
        out.append(f"| {n} | {A['dofs']} | {A['P']:.3f} | {_f(A['hertz_a'], '{:.5f}')} | {tr} |")
    out.append("\n### Run time\n")
    ts = {n: sum(s["time_step_s"] for m in ("adaptive", "uniform") for s in r[m]) + r["reference"]["time_s"]
          for n, r in C.items()}
    out.append("| case | adaptive loop s | uniform loop s | reference + errors s | fosls total s |")
    out.append("|---|---|---|---|---|")
    for n, r in C.items():
        out.append(f"| {n} | {sum(s['time_step_s'] for s in r['adaptive']):.0f} | "
                   f"{sum(s['time_step_s'] for s in r['uniform']):.0f} | {r['reference']['time_s']:.0f} | "
                   f"{sum(s['time_fosls_s'] for m in ('adaptive', 'uniform') for s in r[m]):.0f} |")
    out.append(f"\nTotal wall time of `{summary['command']}`: **{summary['time_total_s']:.0f} s** "
               f"({summary['time_total_s'] / 60:.1f} min, figures {summary.get('time_figures_s', 0):.0f} s; "
               f"sum over cases {sum(ts.values()):.0f} s).\n")
    return "\n".join(out)


def update(outdir):
    outdir = Path(outdir)
    md = Path(str(outdir) + ".md")
    summary = json.loads((outdir / "summary.json").read_text())
    text = tables(summary)
    if md.exists() and BEGIN in md.read_text():
        s = md.read_text()
        a, b = s.index(BEGIN) + len(BEGIN), s.index(END)
        md.write_text(s[:a] + "\n" + text + "\n" + s[b:])
        return md
    (outdir / "tables.md").write_text(text + "\n")
    return outdir / "tables.md"


if __name__ == "__main__":
    print(update(sys.argv[1] if len(sys.argv) > 1 else "docs/adaptive"))
