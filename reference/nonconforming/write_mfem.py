"""PyMFEM 4.10 (serial): a non-conformingly refined mesh written by MFEM's ParaViewDataCollection,
in every form MFEM writes.  Runs in reference/.venv-mfem (Python 3.12); called by make.py.

    reference/.venv-mfem/bin/python reference/nonconforming/write_mfem.py OUT_DIR

Mesh: [0, 2] x [0, 1], MakeCartesian2D(2, 1) in quadrilaterals or triangles, made a
non-conforming mesh (EnsureNCMesh) and element 1 refined once (GeneralRefinement with
nonconforming = 1): the refined element's edge midpoints on its unrefined neighbours' edges are
hanging vertices.  Field: u = (1e-3 x + 2e-4 y, 1e-4 x - 3e-4 y) projected onto H1 of order 1
or 2 (exact: the field is linear), vdim 2, ordering byNODES.  Output: one
ParaViewDataCollection per (order, high-order output on/off, cell kind) in OUT_DIR/<case>/,
SetLevelsOfDetail(order), everything else MFEM's defaults.
"""

import os
import sys

import mfem.ser as M


class Linear(M.VectorPyCoefficient):
    def EvalValue(self, x):
        return [1e-3 * x[0] + 2e-4 * x[1], 1e-4 * x[0] - 3e-4 * x[1]]


def write(out, order, high, quads):
    kind = M.Element.QUADRILATERAL if quads else M.Element.TRIANGLE
    mesh = M.Mesh.MakeCartesian2D(2, 1, kind, True, 2.0, 1.0)
    mesh.EnsureNCMesh()
    mesh.GeneralRefinement(M.intArray([1]), 1, 0)
    assert mesh.Nonconforming()
    fes = M.FiniteElementSpace(mesh, M.H1_FECollection(order, 2), 2)
    u = M.GridFunction(fes)
    u.ProjectCoefficient(Linear(2))
    name = f"p{order}_{'high' if high else 'low'}_{'quad' if quads else 'tri'}"
    cwd = os.getcwd()
    os.chdir(out)
    try:
        pd = M.ParaViewDataCollection(name, mesh)
        pd.SetPrefixPath(".")
        pd.SetLevelsOfDetail(order)
        pd.SetHighOrderOutput(high)
        pd.RegisterField("u", u)
        pd.SetCycle(0)
        pd.SetTime(0.0)
        pd.Save()
    finally:
        os.chdir(cwd)
    return name


def main():
    out = os.path.abspath(sys.argv[1])
    os.makedirs(out, exist_ok=True)
    for quads in (True, False):
        for order in (1, 2):
            for high in (True, False):
                print(write(out, order, high, quads))


if __name__ == "__main__":
    main()
