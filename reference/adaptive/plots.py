"""Figures of the adaptive loop (matplotlib, PNG) and the data behind each (CSV / JSON) — see run.py.
`redraw.py`-style use: every figure is drawn from the CSV/JSON written next to it (draw_* functions read
only those files), so the plots can be redrawn without rerunning the loop:

    reference/.venv/bin/python reference/adaptive/plots.py docs/adaptive
"""
import csv
import json
import sys
from pathlib import Path

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

DPI = 90
STATE_NAMES = {0: "no contact", 1: "stick", 2: "slip"}
STATE_COLORS = {0: "tab:gray", 1: "tab:blue", 2: "tab:red"}
FEATURED = "hertz_coulomb04_nu028"   # the talk's compressible frictional case
BLOCK = "block_coulomb04_nu028"


def _csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow([f"{v:.8g}" if isinstance(v, float) else v for v in r])


def _read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows


def _num(v):
    try:
        return float(v)
    except ValueError:
        return v


# ------------------------------------------------------------------ data writers
def write_data(out, results, kept):
    out = Path(out)
    rows = []
    for name, r in results.items():
        for mode in ("adaptive", "uniform"):
            for s in r[mode]:
                ms = s["marked_shares"]
                rows.append([name, r["geometry"], r["friction"], r["nu"], mode, s["step"], s["cells"], s["dofs"],
                             s["eta"], s.get("error_energy", float("nan")), s.get("efficiency", float("nan")),
                             s["marked"], ms.get("within_2a", float("nan")), s["relative"]])
    _csv(out / "convergence.csv", ["case", "geometry", "friction", "nu", "refinement", "step", "cells", "dofs", "eta",
                                   "error_energy", "efficiency", "marked", "marked_share_within_2a", "relative"], rows)
    if FEATURED in kept:
        k = kept[FEATURED]["adaptive"]
        # deformed mesh after 5 refinements
        i = min(5, len(k["meshes"]) - 1)
        tm, sol = k["meshes"][i]["tm"], k["sols"][i]
        nv = len(tm.p)
        json.dump(dict(case=FEATURED, step=i, points=np.round(tm.p, 8).tolist(), triangles=tm.t.tolist(),
                       displacement=np.round(sol["U"][:nv], 10).tolist()),
                  open(out / "deformed_mesh.json", "w"))
        # contact states per step
        rows = []
        for j, mm in enumerate(k["meshes"]):
            p = mm["prof"]
            for x, y, s in zip(p["x"], p["y"], p["state"]):
                rows.append([j, float(x), float(y), int(s)])
        _csv(out / "contact_states.csv", ["step", "x", "y", "state(0 no contact,1 stick,2 slip)"], rows)
    # contact stress at the last reported adaptive step, Hertz cases
    rows = []
    for name, r in results.items():
        if r["geometry"] != "hertz" or name not in kept:
            continue
        k = kept[name]["adaptive"]
        p = k["meshes"][-1]["prof"]
        a = r["adaptive"][-1]["hertz_a"]
        P = r["adaptive"][-1]["P"]
        for j in range(len(p["x"])):
            if abs(p["x"][j]) <= 0.15:
                rows.append([name, r["friction"], r["nu"], len(k["meshes"]) - 1, float(p["x"][j]), float(p["y"][j]),
                             int(p["state"][j]), float(p["sigma_n"][j]), float(p["sigma_t"][j]), float(p["u_t"][j]),
                             a, 2 * P / (np.pi * a)])
    _csv(out / "contact_stress.csv", ["case", "friction", "nu", "step", "x", "y", "state", "sigma_n", "sigma_t", "u_t",
                                      "hertz_a", "hertz_p0"], rows)
    # marked cells (centroids) of every adaptive step, and the final meshes of the featured / block cases
    rows = []
    for name, r in results.items():
        if name not in kept:
            continue
        for j, mm in enumerate(kept[name]["adaptive"]["meshes"]):
            tm = mm["tm"]
            c = tm.p[tm.t[mm["marked"]]].mean(axis=1)
            for x, y in c:
                rows.append([name, j, round(float(x), 6), round(float(y), 6)])
    _csv(out / "marked_cells.csv", ["case", "step", "centroid_x", "centroid_y"], rows)
    for name in (FEATURED, BLOCK):
        if name in kept:
            mm = kept[name]["adaptive"]["meshes"][-1]
            st = results[name]["adaptive"][-1]
            json.dump(dict(case=name, step=len(kept[name]["adaptive"]["meshes"]) - 1, points=np.round(mm["tm"].p, 8).tolist(),
                           triangles=mm["tm"].t.tolist(), marked=np.flatnonzero(mm["marked"]).tolist(),
                           transitions=st["transitions"], hertz_a=st["hertz_a"]),
                      open(out / f"final_mesh_{name}.json", "w"))


# ------------------------------------------------------------------ figures (from the data files only)
def _cases(rows):
    out = {}
    for r in rows:
        out.setdefault(r["case"], {}).setdefault(r["refinement"], []).append({k: _num(v) for k, v in r.items()})
    return out


def draw_convergence(out):
    rows = _cases(_read_csv(out / "convergence.csv"))
    files = []
    for geo, title in (("hertz", "Hertz contact"), ("block", "block (straight boundaries)")):
        names = [n for n in rows if n.startswith(geo)]
        if not names:
            continue
        fig, axs = plt.subplots(1, 2, figsize=(10, 4.2))
        for ax, fr, frt in zip(axs, ("frictionless", "coulomb04"), ("frictionless", "Coulomb friction 0.4")):
            for nu, col in (("nu028", "tab:blue"), ("nu05", "tab:red")):
                n = f"{geo}_{fr}_{nu}"
                if n not in rows:
                    continue
                for mode, ls, mk in (("adaptive", "-", "o"), ("uniform", "--", "s")):
                    s = rows[n].get(mode, [])
                    if not s:
                        continue
                    d = np.array([q["dofs"] for q in s])
                    e = np.array([q["eta"] for q in s])
                    rate = -np.polyfit(np.log(d), np.log(e), 1)[0] if len(d) > 1 else np.nan
                    ax.loglog(d, e, ls, marker=mk, ms=4, color=col,
                              label=f"{mode}, ν = {0.28 if nu == 'nu028' else 0.5} (rate {rate:.2f})")
            ax.set_xlabel("degrees of freedom")
            ax.set_ylabel("F(u_h, σ_h)^½")
            ax.set_title(f"{title}, {frt}")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        f = out / f"convergence_{geo}.png"
        fig.savefig(f, dpi=DPI)
        plt.close(fig)
        files.append(f)
    # efficiency index per step
    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    for ax, geo in zip(axs, ("hertz", "block")):
        for n, col in zip(sorted(x for x in rows if x.startswith(geo)), ("tab:blue", "tab:red", "tab:green", "tab:orange")):
            for mode, ls in (("adaptive", "-o"), ("uniform", "--s")):
                s = rows[n].get(mode, [])
                ax.plot([q["step"] for q in s], [q["efficiency"] for q in s], ls, ms=4, color=col,
                        label=f"{n.split('_', 1)[1]} {mode}")
        ax.set_xlabel("refinement step")
        ax.set_ylabel("F^½ / ‖u_ref − u_h‖_E")
        ax.set_title(f"efficiency index, {geo}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    f = out / "efficiency.png"
    fig.savefig(f, dpi=DPI)
    plt.close(fig)
    files.append(f)
    return files


def _tri_plot(ax, p, t, face=None, lw=0.3):
    pc = PolyCollection(p[t], facecolors=face if face is not None else "none", edgecolors="k", linewidths=lw)
    ax.add_collection(pc)
    ax.set_aspect("equal")


def draw_deformed(out):
    f = out / "deformed_mesh.json"
    if not f.exists():
        return []
    d = json.load(open(f))
    p, t, u = np.array(d["points"]), np.array(d["triangles"]), np.array(d["displacement"])
    fig, axs = plt.subplots(2, 1, figsize=(9, 7.5), gridspec_kw=dict(height_ratios=[1.2, 1]))
    q = p + u
    _tri_plot(axs[0], q, t)
    axs[0].axhline(0, color="tab:brown", lw=1)
    axs[0].set_xlim(-1.05, 1.05)
    axs[0].set_ylim(-0.05, 1.0)
    axs[0].set_title(f"{d['case']}: deformed mesh (true scale) after {d['step']} refinements, {len(t)} triangles",
                     fontsize=10)
    _tri_plot(axs[1], q, t, lw=0.5)
    axs[1].axhline(0, color="tab:brown", lw=1)
    axs[1].set_xlim(-0.15, 0.15)
    axs[1].set_ylim(-0.001, 0.02)
    axs[1].set_aspect("auto")
    axs[1].set_title("zoom at the contact zone (y stretched 5.7×): the deformed boundary lies on the plane y = 0 "
                     "for |x| < a", fontsize=9)
    fig.tight_layout()
    g = out / "deformed_mesh.png"
    fig.savefig(g, dpi=DPI)
    plt.close(fig)
    return [g]


def draw_states(out):
    f = out / "contact_states.csv"
    if not f.exists():
        return []
    rows = [{k: _num(v) for k, v in r.items()} for r in _read_csv(f)]
    sk = "state(0 no contact,1 stick,2 slip)"
    steps = sorted({int(r["step"]) for r in rows})
    last = steps[-1]
    fig, axs = plt.subplots(2, 1, figsize=(9, 5.5), gridspec_kw=dict(height_ratios=[1, 2.2]))
    for s in (0, 1, 2):
        xs = [r["x"] for r in rows if r["step"] == last and r[sk] == s and 0 <= r["x"] <= 0.1]
        axs[0].plot(xs, np.zeros(len(xs)), "|" if s else ".", ms=14 if s else 6, color=STATE_COLORS[s],
                    label=STATE_NAMES[s])
    axs[0].set_yticks([])
    axs[0].set_xlim(0, 0.1)
    axs[0].set_title(f"grid points on half of Γ_C after {last} refinements ({FEATURED})")
    axs[0].legend(ncol=3, fontsize=8, loc="upper right")
    for st in steps:
        for s in (0, 1, 2):
            xs = [r["x"] for r in rows if r["step"] == st and r[sk] == s and 0 <= r["x"] <= 0.1]
            axs[1].plot(xs, np.full(len(xs), st), "|", ms=8, color=STATE_COLORS[s])
    axs[1].set_xlim(0, 0.1)
    axs[1].set_xlabel("x")
    axs[1].set_ylabel("refinement step")
    axs[1].set_title("Γ_C nodes per refinement step (grey no contact, blue stick, red slip)")
    fig.tight_layout()
    g = out / "contact_states.png"
    fig.savefig(g, dpi=DPI)
    plt.close(fig)
    return [g]


def draw_stress(out):
    f = out / "contact_stress.csv"
    if not f.exists():
        return []
    rows = [{k: _num(v) for k, v in r.items()} for r in _read_csv(f)]
    names = sorted({r["case"] for r in rows})
    if not names:
        return []
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.2))
    if FEATURED in names:
        R = [r for r in rows if r["case"] == FEATURED]
        x = np.array([r["x"] for r in R])
        sn = np.array([r["sigma_n"] for r in R])
        stt = np.array([r["sigma_t"] for r in R])
        a, p0 = R[0]["hertz_a"], R[0]["hertz_p0"]
        xx = np.linspace(-a, a, 301)
        ax = axs[0]
        ax.plot(x, -sn, ".-", ms=3, label="−σ_n (normal)")
        ax.plot(x, stt, ".-", ms=3, label="σ_t (tangential)")
        ax.plot(x, 0.4 * np.abs(sn), ":", color="k", lw=1, label="±F|σ_n| (F = 0.4)")
        ax.plot(x, -0.4 * np.abs(sn), ":", color="k", lw=1)
        ax.plot(xx, p0 * np.sqrt(1 - (xx / a) ** 2), "--", color="tab:gray", lw=1, label="Hertz p(x), frictionless theory")
        ax2 = ax.twinx()
        ax2.plot(x, [r["u_t"] for r in R], color="tab:green", lw=1, label="u_t (slip)")
        ax2.set_ylabel("u_t", color="tab:green")
        ax.set_xlim(-0.12, 0.12)
        ax.set_xlabel("x")
        ax.set_ylabel("contact stress")
        ax.set_title(f"{FEATURED}, step {int(R[0]['step'])}")
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(True, alpha=0.3)
    ax = axs[1]
    for n in names:
        if "frictionless" not in n:
            continue
        R = [r for r in rows if r["case"] == n]
        x = np.array([r["x"] for r in R])
        a, p0 = R[0]["hertz_a"], R[0]["hertz_p0"]
        line, = ax.plot(x, [-r["sigma_n"] for r in R], ".-", ms=3, label=f"−σ_n {n}")
        xx = np.linspace(-a, a, 301)
        ax.plot(xx, p0 * np.sqrt(1 - (xx / a) ** 2), "--", color=line.get_color(), lw=1, label="Hertz")
    ax.set_xlim(-0.12, 0.12)
    ax.set_xlabel("x")
    ax.set_title("frictionless: normal stress vs Hertz")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    g = out / "contact_stress.png"
    fig.savefig(g, dpi=DPI)
    plt.close(fig)
    return [g]


def draw_marked(out):
    files = []
    mc = [{k: _num(v) for k, v in r.items()} for r in _read_csv(out / "marked_cells.csv")] \
        if (out / "marked_cells.csv").exists() else []
    for name in (FEATURED, BLOCK):
        f = out / f"final_mesh_{name}.json"
        if not f.exists():
            continue
        d = json.load(open(f))
        p, t = np.array(d["points"]), np.array(d["triangles"])
        face = np.array(["none"] * len(t), dtype=object)
        face[d["marked"]] = "tab:orange"
        xs = np.array([r["centroid_x"] for r in mc if r["case"] == name])
        ys = np.array([r["centroid_y"] for r in mc if r["case"] == name])
        lines = lambda ax: [ax.axvline(tr["x"], color="tab:red" if 0 in (tr["left"], tr["right"]) else "tab:blue",
                                       lw=0.8) for tr in d["transitions"]]
        if name == FEATURED:
            fig = plt.figure(figsize=(11, 7.2))
            gs = fig.add_gridspec(2, 3, height_ratios=[1, 1.3])
            ax0 = fig.add_subplot(gs[0, :])
            _tri_plot(ax0, p, t, face=list(face), lw=0.25)
            lines(ax0)
            ax0.set_xlim(-0.1, 0.1)
            ax0.set_ylim(-0.001, 0.025)
            ax0.set_title(f"{name}: mesh after {d['step']} refinements ({len(t)} triangles), cells marked in the last "
                          "step orange; red lines: contact ends, blue lines: stick/slip transitions", fontsize=9)
            ends = [tr["x"] for tr in d["transitions"] if 0 in (tr["left"], tr["right"]) and tr["x"] > 0]
            sticks = [tr["x"] for tr in d["transitions"] if 0 not in (tr["left"], tr["right"]) and tr["x"] > 0]
            for j, (xc, lab) in enumerate(((ends[0] if ends else 0.078, "contact end"),
                                           (sticks[0] if sticks else 0.035, "stick/slip transition"))):
                ax = fig.add_subplot(gs[1, j])
                _tri_plot(ax, p, t, face=list(face), lw=0.3)
                lines(ax)
                yc = 1.0 - np.sqrt(1.0 - xc * xc)
                ax.set_xlim(xc - 0.0025, xc + 0.0025)
                ax.set_ylim(yc - 0.0004, yc + 0.0028)
                ax.set_title(f"zoom at the {lab} x = {xc:.4f}", fontsize=9)
            ax = fig.add_subplot(gs[1, 2])
            sel = ys < 0.1
            ax.hist(xs[sel], bins=np.linspace(-0.15, 0.15, 61), color="tab:orange")
            ax.set_xlabel("centroid x of marked cells with y < 0.1 (all steps)", fontsize=8)
            a = d["hertz_a"]
            for s in (-1, 1):
                ax.axvline(s * a, color="tab:red", lw=0.8)
            for tr in d["transitions"]:
                if 0 not in (tr["left"], tr["right"]):
                    ax.axvline(tr["x"], color="tab:blue", lw=0.8)
            ax.set_title("where the loop refined (red ±a Hertz, blue stick/slip)", fontsize=9)
        else:
            fig, axs = plt.subplots(1, 2, figsize=(11, 4.4), gridspec_kw=dict(width_ratios=[1.5, 1]))
            _tri_plot(axs[0], p, t, face=list(face), lw=0.3)
            lines(axs[0])
            axs[0].set_xlim(-1.02, 1.02)
            axs[0].set_ylim(-0.02, 1.02)
            axs[0].set_title(f"{name}: mesh after {d['step']} refinements ({len(t)} triangles), marked cells "
                             "orange;\nblue line: stick/slip transition", fontsize=9)
            axs[1].plot(xs, ys, ".", ms=2, color="tab:orange")
            axs[1].set_aspect("equal")
            axs[1].set_xlim(-1.02, 1.02)
            axs[1].set_ylim(-0.02, 1.02)
            axs[1].set_xlabel("centroids of the marked cells (all steps)")
            axs[1].set_title("where the loop refined", fontsize=9)
        fig.tight_layout()
        g = out / f"marked_{name}.png"
        fig.savefig(g, dpi=DPI)
        plt.close(fig)
        files.append(g)
    return files


def draw_all(out):
    out = Path(out)
    return draw_convergence(out) + draw_deformed(out) + draw_states(out) + draw_stress(out) + draw_marked(out)


def all_figures(out, results, kept, log=print):
    write_data(out, results, kept)
    for f in draw_all(out):
        log(f"wrote {f}")


if __name__ == "__main__":
    draw_all(sys.argv[1] if len(sys.argv) > 1 else "docs/adaptive")
