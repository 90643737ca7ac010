#!/usr/bin/python3
"""Adapt a mesh in parallel to the Hessian metric of a function.

    mpiexec -n 2 python3 adapt_parallel.py [IN [OUT.meshb]]   (default: plate.msh, adapted.meshb)

Rank 0 reads IN, the ranks partition it with PT-Scotch, each computes the
function on its own vertices, the metric and the adaptation run in parallel,
and every rank writes its part of the distributed set OUT (OUT.<rank>.meshb,
OUT.pvtu for ParaView, OUT.manifest). On the way, a value on the vertices
(the number of elements around each, counted by the ranks that own them and
summed across ranks) shows the halo exchanges.
"""
import os, sys
import numpy as np
from mpi4py import MPI
import padapt

comm = MPI.COMM_WORLD
here = os.path.dirname(os.path.abspath(__file__))
src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "plate.msh")
out = sys.argv[2] if len(sys.argv) > 2 else "adapted.meshb"

dm = padapt.DistributedMesh.read(src, comm, overlap=2)   # 2 ghost layers: Hessian recovery
x = dm.local_mesh.points                                 # owned vertices first, then ghosts
dm.add_field("u", np.tanh(40 * (x[:, 1] - 0.3 - 0.1 * np.sin(6 * x[:, 0]))))
dm.metric_from_hessian("u", target=3000, hmin=1e-3, hmax=0.1)
report = dm.adapt()

valence = dm.add_value("valence", "vertex", dtype=np.int32)
owned_cells = dm.local_mesh.cells[:dm.nowned("element")]
np.add.at(valence.data, owned_cells.ravel(), 1)          # each rank counts its own elements
valence.reduce("sum")                                    # ghost copies added into the owners
valence.halo()                                           # owners' totals back to the ghosts
vmax = comm.allreduce(int(valence.owned.max()), op=MPI.MAX)
valence.remove()

dm.write(out)
if comm.rank == 0:
    print("%s -- %d elements on %d ranks in %d iterations, at most %d elements around a vertex"
          % (report.description, report["elements"], comm.size, report["iterations"], vmax))
dm.close()
