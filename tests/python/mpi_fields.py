#!/usr/bin/python3
"""mpi_fields.py -- element and boundary fields of a padapt.DistributedMesh
on 2 processes (mpi4py): a mesh built from numpy with a density (bounded)
and material ids (nearest) and a boundary field is distributed (every
rank's local mesh carries them), adapted by the parallel loop and gathered:
the density's integral kept to 1e-12 relative, its values within the
source range, the material ids' set kept, the boundary values following the
references, the report's transfer figures filled.

Run: mpiexec -n 2 python3 mpi_fields.py (CTest: python.fields.np2).
Exits 0 on every rank on success; an assertion stops the run.
"""
import numpy as np
from mpi4py import MPI

import padapt

comm = MPI.COMM_WORLD


def areas(m):
    x = m.points[m.cells]
    a, b = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def main():
    assert comm.size >= 2, "run with mpiexec -n 2"
    mesh = None
    if comm.rank == 0:
        box = padapt.Mesh.generate_box(2, 8)
        c = box.points[box.cells].mean(axis=1)
        rho = 1 + np.sin(5 * c[:, 0]) * np.cos(3 * c[:, 1])
        mat = 1.0 + (c[:, 0] > 0.4) + 2 * (c[:, 1] > 0.6)
        mesh = padapt.Mesh(box.points, box.cells, box.boundary, boundary_refs=box.boundary_refs,
                           cell_fields={"rho": (rho, "bounded"), "mat": (mat, "nearest")},
                           boundary_fields={"bc": 10.0 * box.boundary_refs})
        i0, lo, hi = np.dot(areas(mesh), rho), rho.min(), rho.max()
    dm = padapt.DistributedMesh.distribute(mesh, comm)
    local = dm.local_mesh
    assert set(local.cell_fields) == {"rho", "mat"} and set(local.boundary_fields) == {"bc"}
    assert local.transfers == {"rho": "bounded", "mat": "nearest"}
    report = dm.adapt(hsiz=0.04)
    t = report["transfer"]
    assert t["nfield"] == 3 and t["nfast"] + t["nclip"] > 0, t
    g = dm.gather()
    if comm.rank == 0:
        assert g.nelem > mesh.nelem
        rho, mat = g.cell_fields["rho"], g.cell_fields["mat"]
        i1 = np.dot(areas(g), rho)
        assert abs(i1 - i0) <= 1e-12 * abs(i0), (i0, i1)
        assert rho.min() >= lo and rho.max() <= hi
        assert set(np.unique(mat)) == {1.0, 2.0, 3.0, 4.0}
        assert np.all(g.boundary_fields["bc"] == 10.0 * g.boundary_refs)
        print("mpi_fields: %d -> %d elements, integral %.17g -> %.17g"
              % (mesh.nelem, g.nelem, i0, i1), flush=True)


if __name__ == "__main__":
    main()
