#!/usr/bin/python3
"""test_gmsh_data.py -- meshio as the judge of what padapt keeps of a Gmsh
file: physical names ($PhysicalNames) and node data views ($NodeData).

Runs, in a scratch working directory (CTest's), with PADAPT = the CLI and
MPIEXEC = mpiexec:
  - padapt generates a 2D and a 3D box (.mesh); meshio turns each into a
    MSH 4.1 file with physical names (field_data), physical tags per cell
    and point data: a view "metric" (2D: a constant anisotropic 3 x 3
    tensor; 3D: a size, one value per node), a scalar "u" = x + 2y + 3z
    and a vector "vel" (z = 0 in 2D), in ASCII and in binary;
  - `padapt convert IN OUT.msh` (ASCII and -binary, and from meshio's
    binary file): meshio reads OUT back with the same names, points and
    point data, bit for bit;
  - `padapt adapt IN -out OUT.msh -nosol`, with no -met: the file's metric
    is the metric (the output has more vertices), and meshio reads OUT with
    the same names, the metric view equal to the constant input metric and
    "u" still equal to x + 2y (linear fields are interpolated exactly);
  - the same on 2 MPI ranks (the output gathered on rank 0 keeps the names);
  - `padapt convert IN OUT.mesh`: Medit has no names nor views, the
    conversion succeeds and keeps the mesh.
Exits 0 on success, 1 naming every mismatch otherwise.
"""
import os
import subprocess
import sys

import numpy as np

try:
    import meshio
except ImportError as e:  # pragma: no cover
    print("test_gmsh_data: cannot import meshio (%s); install python3-meshio"
          % e, file=sys.stderr)
    sys.exit(1)

PADAPT = os.environ.get("PADAPT")
MPIEXEC = os.environ.get("MPIEXEC") or "mpiexec"
failures = []

# Size of the 2D metric: h = 0.2 along x, 0.1 along y.
MET2D = np.array([[25.0, 0, 0], [0, 100.0, 0], [0, 0, 1.0]])
H3D = 0.3  # size of the 3D metric


def fail(msg):
    failures.append(msg)
    print("MISMATCH: " + msg, file=sys.stderr)


def run(*args, mpi=0):
    cmd = ([MPIEXEC, "-n", str(mpi)] if mpi else []) + [PADAPT] + \
        [str(a) for a in args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if p.returncode != 0:
        fail("'%s' exited with %d: %s" % (" ".join(cmd), p.returncode,
                                          (p.stderr or p.stdout).strip()))
        return False
    return True


NAMES = {2: {"fluid": [1, 2], "wall": [2, 1], "unused": [9, 2]},
         3: {"solid": [1, 3], "skin": [2, 2], "edge": [5, 1]}}


def make_input(dim, path):
    """A .msh 4.1 written by meshio from padapt's box, with names and
    views."""
    src = "box%dd.mesh" % dim
    if not run("generate", "box%dd" % dim, 4 if dim == 2 else 2, src):
        return None
    m = meshio.read(src)
    keep = ("triangle", "line") if dim == 2 else ("tetra", "triangle")
    cells, phys = [], []
    # Gmsh puts each node on an entity: boundary nodes on the boundary's
    dim_tags = np.tile([dim, 1], (len(m.points), 1))
    for i, block in enumerate(m.cells):
        if block.type not in keep:
            continue
        cells.append((block.type, block.data))
        tag = 1 if block.type == keep[0] else 2
        phys.append(np.full(len(block.data), tag, dtype=np.int32))
        if tag == 2:
            dim_tags[np.unique(block.data), 0] = dim - 1
    p = m.points
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p))])
    n = len(p)
    u = p[:, 0] + 2 * p[:, 1] + 3 * p[:, 2]
    vel = np.column_stack([p[:, 1], -p[:, 0], p[:, 2] if dim == 3
                           else np.zeros(n)])
    met = (np.tile(MET2D.reshape(1, 9), (n, 1)) if dim == 2
           else np.full(n, H3D))
    out = meshio.Mesh(p, cells,
                      cell_data={"gmsh:physical": phys,
                                 "gmsh:geometrical": phys},
                      point_data={"metric": met, "u": u, "vel": vel,
                                  "gmsh:dim_tags": dim_tags},
                      field_data={k: np.array(v) for k, v in
                                  NAMES[dim].items()})
    meshio.write(path, out, file_format="gmsh", binary=False)
    meshio.write(path.replace(".msh", "_bin.msh"), out, file_format="gmsh",
                 binary=True)
    return out


def names_of(m):
    return {k: [int(x) for x in v] for k, v in m.field_data.items()}


def check_names(what, m, dim):
    got, want = names_of(m), NAMES[dim]
    if got != want:
        fail("%s: physical names %s, expected %s" % (what, got, want))


def check_same(what, ref, path, dim):
    """Our file at path holds ref's names, points and point data exactly."""
    try:
        m = meshio.read(path)
    except Exception as e:  # noqa: BLE001
        fail("%s: meshio cannot read %s: %s" % (what, path, e))
        return
    check_names(what, m, dim)
    if m.points.shape != ref.points.shape or \
            not np.array_equal(m.points, ref.points):
        fail("%s: points differ" % what)
        return
    for k, v in ref.point_data.items():
        if k.startswith("gmsh:"):
            continue
        got = m.point_data.get(k)
        if got is None:
            fail("%s: no point data '%s' (has %s)" %
                 (what, k, sorted(m.point_data)))
        elif got.shape != v.shape or not np.array_equal(got, v):
            fail("%s: point data '%s' differs" % (what, k))


def check_adapted(what, path, dim, nv_in):
    try:
        m = meshio.read(path)
    except Exception as e:  # noqa: BLE001
        fail("%s: meshio cannot read %s: %s" % (what, path, e))
        return
    check_names(what, m, dim)
    n = len(m.points)
    if n <= nv_in:
        fail("%s: %d vertices, no more than the input's %d: the file's "
             "metric was not used" % (what, n, nv_in))
    met = m.point_data.get("metric")
    want = (np.tile(MET2D.reshape(1, 9), (n, 1)) if dim == 2
            else np.full(n, H3D))
    if met is None or met.shape != want.shape or \
            not np.allclose(met, want, rtol=1e-9, atol=0):
        fail("%s: the metric view is not the constant input metric" % what)
    u = m.point_data.get("u")
    p = m.points
    if u is None or not np.allclose(u, p[:, 0] + 2 * p[:, 1] + 3 * p[:, 2],
                                    rtol=0, atol=1e-9):
        fail("%s: field 'u' is not x + 2y + 3z at the output vertices" % what)
    vel = m.point_data.get("vel")
    if vel is None or vel.shape != (n, 3):
        fail("%s: no 3-component view 'vel'" % what)
    elif dim == 2 and np.any(vel[:, 2] != 0):
        fail("%s: the 2D vector 'vel' has a non-zero z" % what)


def main():
    if not PADAPT:
        print("test_gmsh_data: set PADAPT to the padapt executable",
              file=sys.stderr)
        return 1
    for dim in (2, 3):
        inp = "in%dd.msh" % dim
        ref = make_input(dim, inp)
        if ref is None:
            continue
        for binary in (0, 1):
            out = "conv%dd%s.msh" % (dim, "_bin" if binary else "")
            if run("convert", inp, out, *(["-binary"] if binary else [])):
                check_same("convert %dD%s" % (dim, " -binary" if binary
                                              else ""), ref, out, dim)
        # meshio's binary views (4-byte node tags) read the same
        if run("convert", "in%dd_bin.msh" % dim, "frombin%dd.msh" % dim):
            check_same("convert of meshio's binary %dD" % dim, ref,
                       "frombin%dd.msh" % dim, dim)
        # a round trip of our own file is byte for byte
        if run("convert", "conv%dd.msh" % dim, "again%dd.msh" % dim):
            with open("conv%dd.msh" % dim, "rb") as a, \
                    open("again%dd.msh" % dim, "rb") as b:
                if a.read() != b.read():
                    fail("%dD: converting our .msh again changes it" % dim)
        if run("convert", inp, "medit%dd.mesh" % dim):
            mm = meshio.read("medit%dd.mesh" % dim)
            if len(mm.points) != len(ref.points):
                fail("%dD: the .mesh conversion lost vertices" % dim)
        if run("adapt", inp, "-out", "ad%dd.msh" % dim, "-nosol", "-v", "-1"):
            check_adapted("adapt %dD" % dim, "ad%dd.msh" % dim, dim,
                          len(ref.points))
    if run("adapt", "in2d.msh", "-out", "par2d.msh", "-nosol", "-v", "-1",
           mpi=2):
        check_adapted("adapt 2D on 2 ranks", "par2d.msh", 2, 25)
    if failures:
        print("test_gmsh_data: %d mismatch(es)" % len(failures),
              file=sys.stderr)
        return 1
    print("test_gmsh_data: names and views kept by convert and adapt "
          "(ASCII, binary, 1 and 2 ranks)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
