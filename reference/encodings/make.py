#!/usr/bin/env python3
"""Fixture family `encodings`: one small FE solution written in every VTU encoding.

    reference/.venv/bin/python reference/encodings/make.py            # (re)write fixtures/encodings/
    reference/.venv/bin/python reference/encodings/make.py --check    # regenerate in a temp dir, compare
    reference/.venv/bin/python reference/encodings/make.py --out DIR  # write somewhere else

Problem: lower half of the disc of radius 1 centred at (0, 1) (y <= 1), plane
strain, E = 20600, nu = 0.28; u = (0, -0.01) on the top y = 1; u_y = 0 on the
part of the arc with |x| < sin(pi/8) (within pi/8 of the lowest point);
traction-free elsewhere.  Solved with scikit-fem (P1, isoparametric P2 on the
same 128-triangle mesh) and with NGSolve (P1, P2 with mesh.Curve(2)).

See fixtures/encodings/README.md (generated) for the list of files.
"""

from __future__ import annotations

import argparse
import json
import re
import os
import shutil
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import vtufix as V  # noqa: E402

REPO = os.path.dirname(os.path.dirname(HERE))
DEFAULT_OUT = os.path.join(REPO, "fixtures", "encodings")
RTOL = 1e-12  # --check: relative tolerance on solution values (w.r.t. max |array|)

# ---------------------------------------------------------------------------
# the variants
#   writer: meshio | vtk | ngsolve | meshio(merged)
#   relation to the family's canonical file:
#     canonical   it is the canonical file
#     same        same points, cells, arrays (possibly other types/precision)
#     pieces      3 <Piece>s: concatenated pieces repeat interface points;
#                 equal to the canonical after mapping points by coordinates
#     vertex      canonical + one VTK_VERTEX cell between triangles and lines
#     disp2       canonical with 2-component displacement
#     exploded    NGSolve VTKOutput: own point copies per cell; equal to the
#                 merged file after merging coincident points (mean of copies)
# ---------------------------------------------------------------------------
M_BIN = dict(binary=True, compression=None)


def meshio_spec(fmt, comp, header):
    return {"writer": "meshio 5.3.5", "format": fmt, "compressor": comp, "header": header, "byte_order": "LittleEndian"}


def vtk_spec(**o):
    full = dict(V.VTK_DEFAULTS)
    full.update(o)
    fmt = {"appended": "appended " + ("base64" if full["encode"] else "raw"),
           "binary": "inline binary (base64)", "ascii": "ascii"}[full["mode"]]
    comp = {"none": "none", "zlib": "vtkZLibDataCompressor", "lz4": "vtkLZ4DataCompressor",
            "lzma": "vtkLZMADataCompressor"}[full["compressor"]]
    if full["mode"] == "ascii":
        comp = "none"
    bo = {"little": "LittleEndian", "big": "BigEndian"}[full["byte_order"]]
    return {"writer": "vtk 9.7.2 vtkXMLUnstructuredGridWriter", "format": fmt, "compressor": comp,
            "header": full["header"], "byte_order": bo, "vtk_options": o}


def variants():
    v = []

    def add(name, family, relation, spec, note=""):
        v.append(dict(name=name, family=family, relation=relation, spec=spec, note=note))

    for fam in ("p2", "p1"):
        add(f"{fam}_meshio_binary.vtu", fam, "canonical", meshio_spec("inline binary (base64)", "none", "UInt32 (implicit, no header_type attribute)"),
            "CANONICAL file of the family")
        add(f"{fam}_meshio_ascii.vtu", fam, "same", meshio_spec("ascii", "none", "-"),
            "meshio prints floats with '{:.11e}' (12 significant digits): NOT lossless")
        add(f"{fam}_meshio_zlib.vtu", fam, "same", meshio_spec("inline binary (base64)", "vtkZLibDataCompressor", "UInt32 (implicit)"),
            "meshio's default encoding")
        if fam == "p2":
            add("p2_meshio_lzma.vtu", fam, "same", meshio_spec("inline binary (base64)", "vtkLZMADataCompressor", "UInt32 (implicit)"))
            add("p2_meshio_binary_uint64.vtu", fam, "same", meshio_spec("inline binary (base64)", "none", "UInt64"),
                "meshio header_type='UInt64'")
            add("p2_meshio_zlib_uint64.vtu", fam, "same", meshio_spec("inline binary (base64)", "vtkZLibDataCompressor", "UInt64"),
                "meshio header_type='UInt64'")
        add(f"{fam}_vtk_appended_raw.vtu", fam, "same", vtk_spec(), "VTK's default data mode (appended raw)")
        if fam == "p2":
            add("p2_vtk_appended_raw_zlib.vtu", fam, "same", vtk_spec(compressor="zlib", level=6))
            add("p2_vtk_appended_raw_lz4.vtu", fam, "same", vtk_spec(compressor="lz4", level=6),
                "meshio 5.3.5 cannot read LZ4")
            add("p2_vtk_appended_raw_lzma.vtu", fam, "same", vtk_spec(compressor="lzma", level=6))
            add("p2_vtk_appended_base64.vtu", fam, "same", vtk_spec(encode=True), "EncodeAppendedData on")
        add(f"{fam}_vtk_binary_zlib.vtu", fam, "same", vtk_spec(mode="binary", compressor="zlib", level=6))
        add(f"{fam}_vtk_ascii.vtu", fam, "same", vtk_spec(mode="ascii"))
        add(f"{fam}_vtk_bigendian.vtu", fam, "same", vtk_spec(byte_order="big"), "data and block headers big-endian")
        if fam == "p2":
            add("p2_vtk_bigendian_zlib.vtu", fam, "same", vtk_spec(byte_order="big", compressor="zlib", level=6),
                "compression headers big-endian")
            add("p2_vtk_uint32header.vtu", fam, "same", vtk_spec(header="UInt32"))
            add("p2_vtk_pieces3.vtu", fam, "pieces", vtk_spec(pieces=3),
                "3 <Piece> elements (contiguous cell ranges, each with its own copy of the points it uses), "
                "streamed by the stock writer (SetNumberOfPieces(3)) from a piece-aware source; "
                "meshio 5.3.5 reads only the cells of the last piece")
            add("p2_vtk_float32_int32.vtu", fam, "same", vtk_spec(float32=True, idtype="Int32"),
                "points and all float arrays Float32, connectivity and offsets Int32 (32-bit vtkCellArray storage, SetIdTypeToInt32): NOT lossless (float32 rounding; values are the correctly rounded Float64 ones)")
            add("p2_meshio_vertex.vtu", fam, "vertex", meshio_spec("inline binary (base64)", "none", "UInt32 (implicit)"),
                "canonical + one VTK_VERTEX cell (at the lowest point (0,0)) between the triangles and the lines; "
                "its cell data: boundary_tag 0, cell_stress 0")
            add("p2_meshio_disp2.vtu", fam, "disp2", meshio_spec("inline binary (base64)", "none", "UInt32 (implicit)"),
                "displacement with 2 components (x, y), everything else as canonical")
    for k in (1, 2):
        fam = f"ngsolve_p{k}"
        add(f"ngsolve_p{k}_merged.vtu", fam, "canonical", meshio_spec("inline binary (base64)", "none", "UInt32 (implicit)"),
            f"CANONICAL: conforming counterpart of ngsolve_p{k}_exploded.vtu (coincident points merged by "
            "make.py, point values = mean of the copies)")
        add(f"ngsolve_p{k}_exploded.vtu", fam, "exploded",
            {"writer": "NGSolve 6.2.2608 VTKOutput(order=%d, subdivision=0)" % k, "format": "appended raw",
             "compressor": "none", "header": "UInt32 (implicit)", "byte_order": "LittleEndian"},
            "exploded: every cell has its own copies of its nodes; triangles only (no boundary lines, no cell data)")
    return v


# ---------------------------------------------------------------------------
def with_vertex(g):
    """Insert a VTK_VERTEX cell at the lowest point between the blocks."""
    pts = g["points"]
    low = int(np.argmin(pts[:, 1] + 1e-3 * np.abs(pts[:, 0])))
    blocks = V.blocks_of(g)
    ntri = len(blocks[0][1])
    nb = [blocks[0], (V.VTK_VERTEX, np.array([[low]], np.int64))] + blocks[1:]
    cd = {}
    for k, a in g["cell_data"].items():
        cd[k] = np.concatenate([a[:ntri], np.zeros((1, a.shape[1]), a.dtype), a[ntri:]])
    return V.make_grid(pts, nb, g["point_data"], cd, g["component_names"]), ntri


def drop_cell(g, k):
    keep = np.ones(len(g["types"]), bool)
    keep[k] = False
    out = dict(g)
    out["types"] = g["types"][keep]
    sizes = np.diff(g["offsets"])
    out["conn"] = np.concatenate([c for i, (t, c) in enumerate(V.iter_cells(g)) if keep[i]])
    out["offsets"] = np.concatenate([[0], np.cumsum(sizes[keep])])
    out["cell_data"] = {n: a[keep] for n, a in g["cell_data"].items()}
    return out


def with_disp2(g):
    out = dict(g)
    out["point_data"] = dict(g["point_data"])
    out["point_data"]["displacement"] = np.ascontiguousarray(g["point_data"]["displacement"][:, :2])
    return out


def generate(outdir, log=print):
    os.makedirs(outdir, exist_ok=True)
    for f in os.listdir(outdir):
        if f.endswith(".vtu") or f in ("expected.json", "README.md"):
            os.remove(os.path.join(outdir, f))
    sols = {"p1": V.solve_skfem(1), "p2": V.solve_skfem(2)}
    vs = variants()
    vertex_index = {}
    # --- skfem families ---------------------------------------------------
    for var in vs:
        fam, name, spec = var["family"], var["name"], var["spec"]
        if fam not in sols:
            continue
        path = os.path.join(outdir, name)
        g = sols[fam]
        if var["relation"] == "vertex":
            g, vertex_index[name] = with_vertex(g)
        elif var["relation"] == "disp2":
            g = with_disp2(g)
        if spec["writer"].startswith("meshio"):
            if spec["format"] == "ascii":
                V.write_meshio(g, path, binary=False)
            else:
                comp = {"none": None, "vtkZLibDataCompressor": "zlib", "vtkLZMADataCompressor": "lzma"}[spec["compressor"]]
                header = "UInt64" if spec["header"] == "UInt64" else None
                V.write_meshio(g, path, binary=True, compression=comp, header_type=header)
        else:
            V.write_vtk(g, path, **spec["vtk_options"])
    # --- NGSolve families -------------------------------------------------
    ng_info = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in (1, 2):
            produced = V.solve_ngsolve_and_write(k, tmp, f"ngsolve_p{k}")
            names = [os.path.basename(p) for p in produced]
            if names != [f"ngsolve_p{k}.vtu"]:
                raise RuntimeError(f"VTKOutput produced {names}, expected ngsolve_p{k}.vtu only")
            exploded = os.path.join(outdir, f"ngsolve_p{k}_exploded.vtu")
            shutil.copyfile(produced[0], exploded)
            ge = V.read_vtk(exploded)
            dmax = _copy_distance(ge)
            gm, jumps, nmerged = V.merge_grid(ge, tol=1e-9)
            gm["component_names"] = {n: None for n in gm["point_data"]}
            V.write_meshio(gm, os.path.join(outdir, f"ngsolve_p{k}_merged.vtu"), **M_BIN)
            ng_info[f"ngsolve_p{k}"] = {"produced_by_VTKOutput": names, "merged_points": nmerged,
                                        "max_copy_distance": dmax,
                                        "max_jump": {n: {"max_jump": j, "absmax": float(np.abs(ge["point_data"][n]).max())}
                                                     for n, j in jumps.items()}}
    # --- expected.json ----------------------------------------------------
    expected = build_expected(outdir, vs, vertex_index, ng_info, log)
    with open(os.path.join(outdir, "expected.json"), "w") as f:
        json.dump(expected, f, indent=1, sort_keys=False)
        f.write("\n")
    with open(os.path.join(outdir, "README.md"), "w") as f:
        f.write(readme(vs, expected))
    return expected


def _copy_distance(g):
    rep, inv = V.merge_coincident(g["points"], 1e-9)
    d = np.abs(g["points"] - g["points"][rep][inv]).max()
    return float(d)


def relate(var, got, canon, vertex_index):
    """Bring `got` into the canonical's layout according to the relation."""
    rel = var["relation"]
    if rel == "pieces":
        return V.unpiece(got, canon)
    if rel == "vertex":
        k = vertex_index[var["name"]]
        assert got["types"][k] == V.VTK_VERTEX
        return drop_cell(got, k)
    if rel == "disp2":
        assert got["point_data"]["displacement"].shape[1] == 2
        return got
    if rel == "exploded":
        gm, _, _ = V.merge_grid(got, tol=1e-9)
        return gm
    return got


def canon_for(var, canon):
    if var["relation"] == "disp2":
        return with_disp2(canon)
    return canon


def max_rel_diff(got, ref):
    out = {}
    pairs = [("points", got["points"], ref["points"])]
    for kind in ("point_data", "cell_data"):
        for n, b in ref[kind].items():
            if b.dtype.kind == "f":
                pairs.append((f"{kind}/{n}", got[kind][n], b))
    for key, a, b in pairs:
        b = np.asarray(b, np.float64)
        s = np.abs(b).max()
        out[key] = float(np.abs(np.asarray(a, np.float64) - b).max() / s) if s > 0 else 0.0
    return out


def build_expected(outdir, vs, vertex_index, ng_info, log):
    canon = {}
    for var in vs:
        if var["relation"] == "canonical":
            canon[var["family"]] = var["name"]
    canon_grid = {fam: V.read_vtk(os.path.join(outdir, n)) for fam, n in canon.items()}
    files = {}
    for var in vs:
        name = var["name"]
        path = os.path.join(outdir, name)
        fam = var["family"]
        ref = canon_for(var, canon_grid[fam])
        g = V.read_vtk(path)
        entry = {"family": fam, "canonical": canon[fam], "relation": var["relation"]}
        entry.update({k: v for k, v in var["spec"].items() if k != "vtk_options"})
        entry["note"] = var["note"]
        # measured: lossless w.r.t. canonical (vtk reader)
        rg = relate(var, g, ref, vertex_index)
        probs = V.compare_grids(rg, ref, rtol=0.0, float32_exact=False)
        entry["lossless"] = not probs
        entry["lossless_detail"] = probs
        entry["max_rel_diff"] = max_rel_diff(rg, ref)
        if g["points"].dtype == np.float32:
            entry["float32_correctly_rounded"] = not V.compare_grids(rg, ref, rtol=0.0, float32_exact=True)
        # second reader
        entry["readers"] = {"vtk": "ok", "meshio": meshio_status(path, var, g)}
        entry["file_size"] = os.path.getsize(path)
        entry["xml_root"] = V.xml_root_attrs(path)
        entry["data_arrays"] = {d.get("Name", "?"): {k: d[k] for k in ("type", "format", "NumberOfComponents") if k in d}
                                for d in V.xml_data_arrays(path)}
        entry.update(V.summarize(g))
        p = np.asarray(g["points"], np.float64)
        r = np.hypot(p[:, 0] - V.CENTRE[0], p[:, 1] - V.CENTRE[1])
        near = np.abs(r - 1.0) < 0.01
        entry["arc_nodes"] = {"count": int(near.sum()), "max_distance_from_circle": float(np.abs(r[near] - 1.0).max()),
                              "absmax": 1.0}
        if var["relation"] == "exploded":
            entry.update(ng_info[fam])
        files[name] = entry
        log(f"  {name:34s} {entry['file_size']:8d} B  lossless={entry['lossless']!s:5s} meshio={entry['readers']['meshio']}")
    # consistency of the declarations
    for name, e in files.items():
        must = e["relation"] != "exploded" and "NOT lossless" not in e["note"]
        if e["relation"] == "exploded":
            must = True
        if must and not e["lossless"]:
            raise RuntimeError(f"{name}: expected lossless w.r.t. {e['canonical']} but: {e['lossless_detail']}")
        if "NOT lossless" in e["note"] and e["lossless"]:
            raise RuntimeError(f"{name}: declared lossy but reads back bit-identical")
    return {
        "generator": "reference/encodings/make.py",
        "problem": {
            "domain": "lower half of the disc of radius 1 centred at (0,1): x^2+(y-1)^2 <= 1, y <= 1",
            "model": "plane_strain", "youngs_modulus": V.E, "poisson_ratio": V.NU,
            "dirichlet": "u = (0,-0.01) on y = 1 (boundary_tag 2); u_y = 0 on the arc where |x| < sin(pi/8)",
            "neumann": "traction-free on the rest of the arc (boundary_tag 1 marks the whole arc)",
            "skfem_mesh": "polar: centre + rings j=1..8 (radius j/8, 2j segments) = 128 triangles, 81 vertices",
            "stress": "point data 'stress' = L2 projection of C eps(u_h) onto the same Lagrange space (xx,yy,zz,xy); "
                      "cell data 'cell_stress' = element mean of C eps(u_h) (xx,yy,xy), 0 on line cells",
            "ngsolve_mesh": "OCC geometry, maxh=0.15, P2 with mesh.Curve(2); point data 'stress' = NGSolve Set() of "
                            "C eps(u_h) into H1 of the same order (continuous), 'stress_elementwise' = C eps(u_h) (discontinuous)",
        },
        "families": {fam: {"canonical": n} for fam, n in canon.items()},
        "check_tolerance": {"relative": RTOL, "scale": "max |value| of the array (or 1 for geometry)"},
        "files": files,
    }


def meshio_status(path, var, gvtk):
    try:
        gm = V.read_meshio(path)
    except Exception as e:  # noqa: BLE001
        return f"error: {type(e).__name__}: {str(e)[:80]}"
    p = V.compare_grids(gm, gvtk, rtol=0.0)
    return "ok (equal to vtk's reading)" if not p else "WRONG: " + "; ".join(p)[:200]


def readme(vs, expected):
    lines = [
        "# fixtures/encodings",
        "",
        "Generated by `reference/encodings/make.py` (do not edit; regenerate). One small plane-strain",
        "solution (lower half disc, see `expected.json` → `problem`) written in many VTU encodings.",
        "`expected.json` has, per file: family and canonical file, whether it reads back bit-identical",
        "to the canonical (`lossless`), point/cell counts by VTK type, every array with components and",
        "min/max per component, what meshio 5.3.5 makes of it, and for exploded files the merged point",
        "count and the max jump of each point array across the copies of one point.",
        "",
        "Columns: file — writer; format (data mode / encoding); compressor; header type; byte order — notes",
        "",
    ]
    fam_title = {"p2": "## P2 (scikit-fem, isoparametric quadratic: VTK_QUADRATIC_TRIANGLE 22 + VTK_QUADRATIC_EDGE 21)",
                 "p1": "## P1 (scikit-fem, linear: VTK_TRIANGLE 5 + VTK_LINE 3)",
                 "ngsolve_p1": "## NGSolve P1 (VTKOutput order=1: VTK_TRIANGLE 5)",
                 "ngsolve_p2": "## NGSolve P2 (VTKOutput order=2, mesh.Curve(2): VTK_QUADRATIC_TRIANGLE 22)"}
    cur = None
    for var in vs:
        if var["family"] != cur:
            cur = var["family"]
            lines += ["", fam_title[cur], ""]
        s = var["spec"]
        e = expected["files"][var["name"]]
        c = f"`{e['canonical']}`"
        rel = var["relation"]
        if rel == "canonical":
            loss = "CANONICAL"
        elif rel == "exploded":
            loss = f"equal to {c} after merging coincident points ({e['merged_points']} points)"
        elif e["lossless"]:
            loss = {"same": f"lossless vs {c}",
                    "pieces": f"lossless vs {c} after mapping the pieces' points onto it by coordinates",
                    "vertex": f"lossless vs {c} after dropping the VTK_VERTEX cell",
                    "disp2": f"lossless vs {c} (displacement x, y)"}[rel]
        else:
            worst = max(e["max_rel_diff"].values())
            loss = f"LOSSY vs {c} (max relative difference {worst:.1e})"
        header = s["header"]
        if s["format"] == "ascii":
            header = "n/a" + (f" (header_type=\"{e['xml_root']['header_type']}\" written anyway)"
                              if "header_type" in e["xml_root"] else "")
        note = var["note"].replace("CANONICAL file of the family", "").replace("CANONICAL: ", "")
        lines.append(f"- `{var['name']}` ({e['file_size']} B) — {s['writer']}; {s['format']}; {s['compressor']}; "
                     f"{header}; {s['byte_order']} — {loss}" + (f"; {note}" if note else ""))
    f = expected["files"]
    ng2 = f["ngsolve_p2_exploded.vtu"]
    lines += [
        "",
        "## Notes for readers",
        "",
        "- scikit-fem files: all triangles first, then the boundary line cells along the counter-clockwise",
        "  boundary (arc from (-1,1) to (1,1), then the top from (1,1) to (-1,1)), each oriented with the",
        "  body on its left. `boundary_tag` (Int32 cell data): 0 triangles, 1 arc, 2 top. `cell_stress`",
        "  (xx,yy,xy) is 0 on line cells. P2 mid-edge nodes of arc edges lie on the circle (|r-1| <= 1.2e-16).",
        "- meshio: `version=\"0.1\"`, no `header_type` attribute unless UInt64 (so UInt32), `types` written as",
        "  **Int64** (not UInt8), connectivity/offsets Int64, no ComponentName attributes. In compressed",
        "  inline arrays the block header and the compressed data are base64-encoded separately and",
        "  concatenated (so `=` padding can occur in the middle of the text); VTK's inline binary does the same.",
        "- VTK: `version=\"1.0\"` with UInt64 headers, `\"0.1\"` with UInt32; `IdType=\"1\"` on connectivity",
        "  (absent with 32-bit cell storage); `RangeMin`/`RangeMax` attributes, empty (`\"\"`) on the Cells",
        "  arrays in appended mode; attribute values padded with spaces (`NumberOfPoints=\"289\"   `);",
        "  `ComponentName0..` on `stress` (xx,yy,zz,xy) and `cell_stress` (xx,yy,xy); appended data after `_`.",
        "- meshio 5.3.5 cannot read LZ4 (`KeyError: 'vtkLZ4DataCompressor'`) and reads a multi-piece file",
        "  wrongly (points of all pieces, cells of the last piece only): see `readers` in expected.json.",
        f"- NGSolve VTKOutput (6.2.2608): one Do() writes just `<name>.vtu` (a second Do() on the same",
        f"  object writes `<name>_step00001.vtu` and `<name>.pvd`), `version=\"1.0\"`, no header_type (UInt32), appended raw,",
        f"  Int32 connectivity/offsets, Float64 data; triangles only. Copies of one node differ in their",
        f"  coordinates by up to {ng2['max_copy_distance']:.1e} (merge with a tolerance). P2 (Curve(2)) mid-edge",
        f"  nodes on the arc are off the circle by up to {ng2['arc_nodes']['max_distance_from_circle']:.1e}. `displacement` and",
        f"  `stress` (continuous Set() projection) jump by 0 across copies; `stress_elementwise` (C eps(u_h))",
        f"  jumps by up to {max(ng2['max_jump']['stress_elementwise']['max_jump']):.0f} (see `max_jump`).",
        "",
    ]
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# --check
# ---------------------------------------------------------------------------
def compare_json(a, b, path="", scale=1.0, out=None):
    if out is None:
        out = []
    if isinstance(a, dict) and isinstance(b, dict):
        if "absmax" in a and isinstance(a["absmax"], (int, float)):
            scale = max(float(a["absmax"]), 1e-300)
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: present in only one of committed/regenerated")
            elif k in ("file_size", "lossless_detail"):
                continue  # byte-identical files are not required
            else:
                compare_json(a[k], b[k], f"{path}/{k}", scale, out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
        else:
            for i, (x, y) in enumerate(zip(a, b)):
                compare_json(x, y, f"{path}[{i}]", scale, out)
    elif isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or a is None:
        if a != b:
            out.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if isinstance(a, int) and isinstance(b, int):
            if a != b:
                out.append(f"{path}: {a} != {b}")
        elif not abs(a - b) <= RTOL * max(scale, abs(a), abs(b)):
            out.append(f"{path}: {a!r} != {b!r} (relative tolerance {RTOL})")
    elif a != b:
        out.append(f"{path}: {a!r} != {b!r}")
    return out


def check(committed_dir):
    problems = []
    if not os.path.isdir(committed_dir):
        print(f"encodings --check: {committed_dir} does not exist; run make.py first", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory(prefix="fosls-encodings-") as tmp:
        generate(tmp, log=lambda *a: None)
        have = sorted(f for f in os.listdir(committed_dir) if not f.startswith("."))
        want = sorted(os.listdir(tmp))
        for f in sorted(set(have) ^ set(want)):
            problems.append(f"{f}: {'not regenerated (stale?)' if f in have else 'missing from ' + committed_dir}")
        for f in want:
            if f not in have:
                continue
            a, b = os.path.join(committed_dir, f), os.path.join(tmp, f)
            if f.endswith(".vtu"):
                try:
                    ga, gb = V.read_vtk(a), V.read_vtk(b)
                except Exception as e:  # noqa: BLE001
                    problems.append(f"{f}: cannot read: {e}")
                    continue
                for p in V.compare_grids(ga, gb, rtol=RTOL, allow_extra=False):
                    problems.append(f"{f}: {p}")
                if V.xml_root_attrs(a) != V.xml_root_attrs(b):
                    problems.append(f"{f}: <VTKFile> attributes differ: {V.xml_root_attrs(a)} vs {V.xml_root_attrs(b)}")
                da, db = V.xml_data_arrays(a), V.xml_data_arrays(b)
                strip = lambda L: [{k: v for k, v in d.items() if k in ("Name", "type", "format", "NumberOfComponents")} for d in L]
                if strip(da) != strip(db):
                    problems.append(f"{f}: <DataArray> declarations differ")
            elif f == "expected.json":
                with open(a) as fa, open(b) as fb:
                    ja, jb = json.load(fa), json.load(fb)
                for p in compare_json(ja, jb):
                    problems.append(f"expected.json{p}")
            else:
                # The README lists each file's size in bytes: compressed and ascii sizes follow the
                # solver's last digits, which vary with the machine's BLAS kernels (the VTU
                # contents are compared above at RTOL), so the sizes are masked.
                sizes = lambda t: re.sub(r"\(\d+ B\)", "(N B)", t)
                with open(a) as fa, open(b) as fb:
                    if sizes(fa.read()) != sizes(fb.read()):
                        problems.append(f"{f}: differs from the regenerated one")
    problems += self_test_check_writer(committed_dir)
    if problems:
        print(f"encodings --check: FAILED, {len(problems)} mismatch(es) between {committed_dir} and a fresh regeneration:",
              file=sys.stderr)
        for p in problems[:50]:
            print("  " + p, file=sys.stderr)
        print("  (regenerate with: reference/.venv/bin/python reference/encodings/make.py)", file=sys.stderr)
        return 1
    print(f"encodings --check: OK ({len(want)} files in {os.path.relpath(committed_dir, REPO)} match a fresh regeneration)")
    return 0


def self_test_check_writer(d):
    """check_writer.py must accept every lossless same-layout fixture and
    reject the lossy ASCII one."""
    import contextlib
    import io

    import check_writer

    probs = []
    canon = os.path.join(d, "p2_meshio_binary.vtu")
    both = [os.path.join(d, v["name"]) for v in variants()
            if v["family"] == "p2" and v["relation"] in ("canonical", "same") and "NOT lossless" not in v["note"]
            and "lz4" not in v["name"]]
    cases = [(both, ["--readers", "vtk,meshio"], 0),
             ([os.path.join(d, "p2_vtk_appended_raw_lz4.vtu"), os.path.join(d, "p2_vtk_pieces3.vtu"),
               os.path.join(d, "p2_vtk_float32_int32.vtu")], ["--readers", "vtk"], 0),
             ([os.path.join(d, "p2_meshio_ascii.vtu")], [], 1),
             ([os.path.join(d, "p2_meshio_ascii.vtu")], ["--rtol", "1e-11"], 0)]
    for files, opts, want in cases:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            rc = check_writer.main(files + opts + ["--like", canon])
        if rc != want:
            probs.append(f"check_writer.py self-test: exit {rc}, expected {want} for {opts}: {buf.getvalue()[:300]}")
    return probs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="regenerate into a temp dir and compare with the committed fixtures")
    ap.add_argument("--out", default=DEFAULT_OUT, help="output directory (default fixtures/encodings)")
    args = ap.parse_args()
    if args.check:
        return check(args.out)
    print(f"writing {args.out}")
    generate(args.out)
    total = sum(os.path.getsize(os.path.join(args.out, f)) for f in os.listdir(args.out))
    print(f"total {total} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
