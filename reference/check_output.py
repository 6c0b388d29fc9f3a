#!/usr/bin/env python3
"""Reads a VTU written by `fosls estimate --output` with BOTH meshio and VTK and checks that
the per-cell arrays of DESIGN.md §8 are there, one value per cell, and that both readers agree.

    reference/.venv/bin/python reference/check_output.py OUT.vtu [--arrays eta,eta_constitutive,...]

One line per reader; exit status 0 when both read the file and agree, 1 otherwise.
"""
import argparse
import sys

import meshio
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

DEFAULT = "eta,eta_squared,eta_constitutive,eta_equilibrium,eta_complementarity,eta_friction,contact_state"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--arrays", default=DEFAULT)
    args = ap.parse_args()
    names = [n for n in args.arrays.split(",") if n]
    ok = True

    m = meshio.read(args.file)
    ncells = sum(len(c.data) for c in m.cells)
    got_meshio = {}
    for n in names:
        if n not in m.cell_data:
            print(f"FAIL meshio: no cell array {n!r}")
            ok = False
            continue
        got_meshio[n] = np.concatenate([np.asarray(b).reshape(len(b), -1) for b in m.cell_data[n]])
        if len(got_meshio[n]) != ncells:
            print(f"FAIL meshio: {n} has {len(got_meshio[n])} tuples for {ncells} cells")
            ok = False
    print(f"meshio: {len(m.points)} points, {ncells} cells, arrays {sorted(m.cell_data)}")

    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(args.file)
    r.Update()
    g = r.GetOutput()
    if g.GetNumberOfCells() != ncells:
        print(f"FAIL vtk: {g.GetNumberOfCells()} cells, meshio {ncells}")
        ok = False
    for n in names:
        a = g.GetCellData().GetArray(n)
        if a is None:
            print(f"FAIL vtk: no cell array {n!r}")
            ok = False
            continue
        v = vtk_to_numpy(a).reshape(g.GetNumberOfCells(), -1)
        if n in got_meshio and not np.array_equal(v, got_meshio[n]):
            print(f"FAIL vtk and meshio disagree on {n}")
            ok = False
    print(f"vtk: {g.GetNumberOfPoints()} points, {g.GetNumberOfCells()} cells")
    print("OK" if ok else "FAILED", args.file)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
