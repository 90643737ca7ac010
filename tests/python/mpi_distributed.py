#!/usr/bin/python3
"""mpi_distributed.py -- padapt.DistributedMesh on 2 processes (mpi4py):
distribute a mesh built from numpy, values and halo exchange / reduction as
numpy arrays against the global ids, entity sets, the Hessian metric and
the parallel adaptation (fields interpolated exactly, the gathered result
judged by meshio), a distributed set written and read back with the same
checksum, kept through redistribute, rebalance and reorder, and bad input on one
rank refused on both.

Run: mpiexec -n 2 python3 mpi_distributed.py (CTest: python.distributed.np2).
Exits 0 on every rank on success; an assertion stops the run (mpi4py
aborts the job on an uncaught exception).
"""
import sys

import meshio
import numpy as np
from mpi4py import MPI

import padapt

comm = MPI.COMM_WORLD
rank, size = comm.rank, comm.size


def log(msg):
    if rank == 0:
        print(msg, flush=True)


def main():
    assert size >= 2, "run with mpiexec -n 2"
    # ---- a 2D mesh from numpy on rank 0, distributed with two ghost layers
    mesh = None
    if rank == 0:
        box = padapt.Mesh.generate_box(2, 16)
        mesh = padapt.Mesh(box.points, box.cells, box.boundary, boundary_refs=box.boundary_refs)
    dm = padapt.DistributedMesh.distribute(mesh, comm, overlap=2)
    dm.check()
    assert dm.nglobal("element") == 512 and dm.nglobal("vertex") == 289
    assert comm.allreduce(dm.nowned("element")) == 512
    assert dm.neighbours() == [1 - rank]
    log("distributed: %r" % dm)

    # ---- values: owner -> ghost halo, ghost -> owner reduction
    nv, no = dm.nlocal("vertex"), dm.nowned("vertex")
    gid = dm.global_ids("vertex")
    assert len(np.unique(gid)) == nv and (dm.owners("vertex")[:no] == rank).all()
    v = dm.add_value("gid", "vertex", ncomp=2, dtype=np.int64)
    assert v.data.shape == (nv, 2) and (v.data == 0).all()
    v.data[:no, 0] = gid[:no]
    v.data[:no, 1] = rank
    v.data[no:] = -1
    v.halo()
    np.testing.assert_array_equal(v.data[:, 0], gid)
    np.testing.assert_array_equal(v.data[:, 1], dm.owners("vertex"))
    c = dm.add_value("copies", "vertex")
    c.data[:] = 1.0
    c.reduce("sum")
    # every copy counted once at its owner: the copies over all ranks
    assert comm.allreduce(c.owned.sum()) == comm.allreduce(nv)
    assert (c.owned >= 1).all() and (c.data[no:] == 1).all()
    inter, front = dm.entities("element", "interior"), dm.entities("element", "frontier")
    assert len(np.intersect1d(inter, front)) == 0
    np.testing.assert_array_equal(np.sort(np.r_[inter, front]), np.arange(dm.nowned("element")))
    v.remove()
    c.remove()

    # ---- the Hessian metric of a field, then the parallel adaptation
    x = dm.local_mesh.points
    dm.add_field("u", np.tanh(8 * (x[:, 0] - 0.5)) + x[:, 1] ** 2)
    dm.add_field("lin", 1 + x[:, 0] + 2 * x[:, 1])
    dm.metric_from_hessian("u", target=1500)
    assert abs(dm.metric_complexity() - 1500) < 15
    before = dm.checksum()
    rep = dm.adapt()
    dm.check()
    assert rep["processes"] == 2 and rep["iterations"] >= 1, dict(rep)
    assert rep["edge_in_range"] >= 0.85, rep.description
    log("adapted: %s (%d elements, %d iterations)" % (rep.description, rep["elements"], rep["iterations"]))
    assert dm.checksum() != before
    lm = dm.local_mesh
    p = lm.points
    np.testing.assert_allclose(lm.fields["lin"], 1 + p[:, 0] + 2 * p[:, 1], atol=1e-9)
    g = dm.gather()
    if rank == 0:
        g.check()
        assert g.nelem == rep["elements"]
        g.write("gathered.mesh")
        r = meshio.read("gathered.mesh")
        t = r.points[r.cells_dict["triangle"]][:, :, :2]
        area = 0.5 * np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        assert (area > 0).all() and abs(area.sum() - 1) < 1e-9
        assert len(r.cells_dict["triangle"]) == rep["elements"]
    else:
        assert g is None

    # ---- a distributed set, written then read back by the same 2 ranks
    dm.write("set.meshb")
    sum1 = dm.checksum()
    with padapt.DistributedMesh.read("set.meshb", comm) as back:
        back.check()
        assert back.nglobal("element") == rep["elements"]
        assert back.checksum() == sum1, "checksum changed through the set"
        # moving elements changes neither the mesh nor its checksum
        ne = back.nowned("element")
        back.redistribute(np.where(np.arange(ne) < ne // 2, 0, 1))
        back.check()
        assert back.checksum() == sum1, "checksum changed by redistribute"
        moved = back.rebalance(tol=1.05)
        back.check()
        counts, imbalance, cut = back.partition_stats()
        assert counts.sum() == rep["elements"] and imbalance <= 1.06 and cut > 0, (counts, imbalance)
        assert back.checksum() == sum1 and isinstance(moved, int)
        back.reorder()
        back.check()
        assert back.checksum() == sum1, "checksum changed by reorder"

    # ---- bad input on one rank only: every rank raises, none hangs
    met = np.full(dm.nowned("vertex"), 0.05)
    if rank == 1:
        met[0] = np.nan
    try:
        dm.set_metric(met)
        raise AssertionError("NaN metric accepted")
    except ValueError as exc:
        assert "rank 1: metric" in str(exc), str(exc)
    try:
        dm.add_value("bad", "vertex", dtype=np.complex128)
        raise AssertionError("complex value accepted")
    except ValueError as exc:
        assert "dtype" in str(exc)
    dm.set_metric(np.full(dm.nowned("vertex"), 0.05))  # still usable
    dm.close()
    log("mpi_distributed: OK")


if __name__ == "__main__":
    try:
        main()
    except BaseException:
        import traceback
        traceback.print_exc()
        sys.stdout.flush()
        comm.Abort(1)
