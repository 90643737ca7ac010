#!/usr/bin/python3
"""test_meshio.py -- meshio as an independent judge of padapt's mesh files.

Runs, in a scratch working directory (CTest's), with PADAPT = the CLI:
    $PADAPT generate box2d 5 a.mesh        $PADAPT generate box3d 3 b.mesh
    $PADAPT convert X.mesh X.msh | X_bin.msh -binary | X.vtu | X.meshb
and checks with meshio (Debian's python3-meshio, 5.x):
  - meshio reads our .msh (MSH 4.1 ASCII and binary) and .vtu with the same
    vertex count as meshio's reading of our .mesh, coordinates equal to
    1e-12 (and bit for bit between .msh, binary .msh and .vtu, which all
    carry exact doubles), and per cell type the same cells (as a multiset of
    vertex tuples) and the same references (Gmsh physical tags = Medit refs);
    the .vtu holds the elements, boundary entities and feature edges, with
    point data "ref", "metric" (3 x 3, equal to the .sol's tensors) and
    "size" (S with S M S = I), and cell data "ref", "entity" (0/1/2 by
    kind), "quality" (NaN off the elements) and "edge_max"; the .meshb
    matches the .mesh;
  - files written by meshio itself (Medit, Gmsh 4.1 ASCII and binary with
    entities and physical tags, Gmsh 2.2 with one cell block) are read by
    `$PADAPT stats FILE -json s.json` with
    the same vertex, element and boundary counts, and padapt's conversion of
    meshio's binary .msh to .vtu gives back the same coordinates bit for bit.
Exits 0 on success, 1 naming every mismatch otherwise.
"""
import concurrent.futures
import json
import os
import subprocess
import sys

import numpy as np

try:
    import meshio
except ImportError as e:  # pragma: no cover
    print("test_meshio: cannot import meshio (%s); install python3-meshio" % e,
          file=sys.stderr)
    sys.exit(1)

PADAPT = os.environ.get("PADAPT")
failures = []


def fail(msg):
    failures.append(msg)
    print("MISMATCH: " + msg, file=sys.stderr)


class CliError(Exception):
    pass


def run(*args):
    """Run the CLI; raise CliError (recorded as a failure) if it fails."""
    cmd = [PADAPT] + [str(a) for a in args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        msg = "'%s' exited with %d: %s" % (" ".join(cmd[1:]), p.returncode,
                                         (p.stderr or p.stdout).strip())
        fail(msg)
        raise CliError(msg)
    return p


def by_type(mesh):
    """Cells of a meshio mesh as {type: (cells (n x k), refs or None)}."""
    out = {}
    keys = ("gmsh:physical", "medit:ref", "ref")
    for i, block in enumerate(mesh.cells):
        refs = None
        for k in keys:
            if k in mesh.cell_data:
                refs = np.asarray(mesh.cell_data[k][i]).astype(np.int64)
                break
        data = np.asarray(block.data, dtype=np.int64)
        if refs is None:
            refs = np.full(len(data), np.iinfo(np.int64).min)
        if block.type in out:
            c, r = out[block.type]
            out[block.type] = (np.vstack([c, data]), np.concatenate([r, refs]))
        else:
            out[block.type] = (data, refs)
    return out


def multiset(cells, refs, with_refs):
    rows = [tuple(c) + ((int(r),) if with_refs else ()) for c, r in
            zip(cells.tolist(), refs.tolist())]
    return sorted(rows)


def xyz(points):
    """Points as n x 3 (meshio gives 2 columns for 2D Medit meshes)."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p))])
    return p


def compare(name, ref, got, types, with_refs):
    """Compare meshio's reading of one of our files with the reference."""
    if len(got.points) != len(ref.points):
        fail("%s: %d vertices, the .mesh has %d" % (name, len(got.points),
                                                     len(ref.points)))
        return
    pr, pg = xyz(ref.points), xyz(got.points)
    if not np.allclose(pr, pg, rtol=0, atol=1e-12):
        k = int(np.argmax(np.abs(pr - pg).max(axis=1)))
        fail("%s: vertex %d is %s, the .mesh has %s" % (name, k, pg[k], pr[k]))
    cr, cg = by_type(ref), by_type(got)
    for t in types:
        if t not in cr:
            fail("%s: meshio finds no %s cells in the reference .mesh" %
                 (name, t))
            continue
        if t not in cg:
            fail("%s: no %s cells (the .mesh has %d)" % (name, t, len(cr[t][0])))
            continue
        if len(cg[t][0]) != len(cr[t][0]):
            fail("%s: %d %s cells, the .mesh has %d" %
                 (name, len(cg[t][0]), t, len(cr[t][0])))
            continue
        if multiset(*cg[t], False) != multiset(*cr[t], False):
            fail("%s: the %s cells differ from the .mesh's" % (name, t))
        elif with_refs and multiset(*cg[t], True) != multiset(*cr[t], True):
            fail("%s: the references of the %s cells differ from the .mesh's"
                 % (name, t))


def stats_counts(path, tag):
    js = "s_%s.json" % tag
    if os.path.exists(js):
        os.remove(js)
    run("stats", path, "-json", js)
    with open(js) as f:
        s = json.load(f)
    return s["vertices"], s["elements"], s["boundary"]


def check_case(stem, shape, n, elem, bdry, feature):
    mesh_file = stem + ".mesh"
    run("generate", shape, n, mesh_file)
    ref = meshio.read(mesh_file)
    dim = 3 if elem == "tetra" else 2
    types = [elem, bdry] + ([feature] if feature else [])
    # meshio's reading of the .mesh must hold the expected kinds of cells.
    for t in types:
        if t not in ref.cells_dict:
            fail("%s: meshio finds no %s cells" % (mesh_file, t))

    # Our Gmsh files, ASCII and binary.
    msh, msh_bin = stem + ".msh", stem + "_bin.msh"
    run("convert", mesh_file, msh)
    p = subprocess.run([PADAPT, "convert", mesh_file, msh_bin, "-binary"],
                       capture_output=True, text=True, timeout=600)
    have_bin = p.returncode == 0
    if not have_bin:
        if "-binary" in p.stderr and "unknown" in p.stderr:
            print("note: this CLI has no 'convert -binary': binary .msh "
                  "not checked", file=sys.stderr)
        else:
            fail("'convert %s %s -binary' exited with %d: %s" %
                 (mesh_file, msh_bin, p.returncode, p.stderr.strip()))
    expect_header = [(msh, b"4.1 0 8")] + ([(msh_bin, b"4.1 1 8")]
                                           if have_bin else [])
    got_msh = {}
    for path, header in expect_header:
        with open(path, "rb") as f:
            head = f.read(64)
        if not head.startswith(b"$MeshFormat\n" + header):
            fail("%s: header is %r, expected MSH %s" % (path, head[:24], header))
        got_msh[path] = meshio.read(path)
        compare(path, ref, got_msh[path], types, with_refs=True)
        got = got_msh[path]
        if np.any(got.points[:, 2] != 0) and dim == 2:
            fail("%s: a 2D mesh has non-zero z" % path)

    # VTK XML: elements, boundary entities and feature edges as their own
    # cells, with references, the entity kind and quality; the metric as a
    # full 3 x 3 tensor and the size tensor M^(-1/2); edge lengths on
    # request.
    vtu = stem + ".vtu"
    sol = stem + ".sol"
    run("metric", "shell", mesh_file, sol)
    run("convert", mesh_file, vtu, "-met", sol, "-diag")
    got_vtu = meshio.read(vtu)
    compare(vtu, ref, got_vtu, types, with_refs=True)
    ncell = sum(len(c.data) for c in got_vtu.cells)
    for key, kind, size in (("ref", "point", len(ref.points)),
                            ("ref", "cell", ncell), ("quality", "cell", ncell),
                            ("entity", "cell", ncell),
                            ("edge_max", "cell", ncell),
                            ("metric", "point", len(ref.points)),
                            ("size", "point", len(ref.points))):
        data = got_vtu.point_data if kind == "point" else got_vtu.cell_data
        if key not in data:
            fail("%s: no %s data '%s'" % (vtu, kind, key))
            continue
        arr = data[key] if kind == "point" else np.concatenate(data[key])
        if len(arr) != size:
            fail("%s: %s data '%s' has %d values, expected %d" %
                 (vtu, kind, key, len(arr), size))
    want_kind = {elem: 0, bdry: 1, feature: 2}
    for c, ent, q in zip(got_vtu.cells, got_vtu.cell_data.get("entity", []),
                         got_vtu.cell_data.get("quality", [])):
        if np.any(ent != want_kind.get(c.type, -1)):
            fail("%s: %s cells have entity %s" % (vtu, c.type, np.unique(ent)))
        if (c.type == elem) != bool(np.all(np.isfinite(q))):
            fail("%s: quality of the %s cells: %s" % (vtu, c.type, q[:3]))
    if "metric" in got_vtu.point_data and "size" in got_vtu.point_data:
        # the tensors of our .sol (Medit order m11 m12 m22 [m13 m23 m33])
        with open(sol) as f:
            tok = f.read().split()
        i = tok.index("SolAtVertices")
        nval = 3 if dim == 2 else 6
        vals = np.array(tok[i + 4:i + 4 + nval * len(ref.points)],
                        dtype=float).reshape(-1, nval)
        met = got_vtu.point_data["metric"].reshape(-1, 3, 3)
        size = got_vtu.point_data["size"].reshape(-1, 3, 3)
        order = [(0, 0), (0, 1), (1, 1)] + ([(0, 2), (1, 2), (2, 2)]
                                            if dim == 3 else [])
        for k, (a, b) in enumerate(order):
            if not (np.allclose(met[:, a, b], vals[:, k], rtol=1e-12) and
                    np.allclose(met[:, b, a], vals[:, k], rtol=1e-12)):
                fail("%s: metric component %d%d differs from %s" %
                     (vtu, a + 1, b + 1, sol))
        d = slice(0, dim)
        prod = size[:, d, d] @ met[:, d, d] @ size[:, d, d]
        if not np.allclose(prod, np.eye(dim)[None], atol=1e-9):
            fail("%s: the size tensor S does not give S M S = I" % vtu)
        if dim == 2 and np.any(met[:, 2, :] != 0):
            fail("%s: a 2D metric has a third row" % vtu)
    if np.any(got_vtu.points[:, 2] != 0) and dim == 2:
        fail("%s: a 2D mesh has non-zero z" % vtu)

    # The files that carry exact doubles agree bit for bit.
    for path, got in got_msh.items():
        if not np.array_equal(got.points, got_vtu.points):
            fail("%s and %s: coordinates differ" % (path, vtu))
    meshb = stem + ".meshb"
    run("convert", mesh_file, meshb)
    compare(meshb, ref, meshio.read(meshb), types, with_refs=True)

    # meshio's own files, read by padapt stats: same counts as meshio's
    # reading of our .mesh (every boundary entity of a box is listed).
    elems = ref.cells_dict[elem]
    bd = ref.cells_dict.get(bdry, np.zeros((0, dim), dtype=int))
    want = (len(ref.points), len(elems), len(bd))
    feat = ref.cells_dict.get(feature, np.zeros((0, 2), dtype=int)) \
        if feature else None
    # Entity of each node for Gmsh: interior nodes on the volume/surface,
    # boundary nodes on a boundary entity, feature-edge nodes on a curve.
    dim_tags = np.tile([dim, 1], (len(ref.points), 1))
    dim_tags[np.unique(bd), 0] = dim - 1
    blocks = [(elem, elems), (bdry, bd)]
    phys = [np.full(len(elems), 1), np.full(len(bd), 2)]
    if feat is not None and len(feat):
        dim_tags[np.unique(feat), 0] = 1
        blocks.append((feature, feat))
        phys.append(np.full(len(feat), 3))
    full = meshio.Mesh(
        ref.points, blocks,
        point_data={"gmsh:dim_tags": dim_tags},
        cell_data={"gmsh:physical": phys,
                   "gmsh:geometrical": [np.full(len(b[1]), 1) for b in blocks]})
    single = meshio.Mesh(ref.points, [(elem, elems)])
    written = [
        ("mio_%s.mesh" % stem, lambda p: meshio.write(p, ref,
                                                      file_format="medit")),
        ("mio_%s.msh" % stem, lambda p: meshio.write(
            p, full, file_format="gmsh", binary=False)),
        ("mio_%s_bin.msh" % stem, lambda p: meshio.write(
            p, full, file_format="gmsh", binary=True)),
        ("mio_%s_22.msh" % stem, lambda p: meshio.write(
            p, single, file_format="gmsh22", binary=False)),
    ]
    for path, write in written:
        try:
            write(path)
        except Exception as e:  # a meshio failure is not ours, but say it
            fail("meshio could not write %s: %s" % (path, e))
            continue
        try:
            got = stats_counts(path, os.path.basename(path))
        except CliError:
            continue
        if got != want:
            fail("%s (written by meshio): stats gives vertices, elements, "
                 "boundary = %s, expected %s" % (path, got, want))

    # padapt's reading of meshio's binary .msh keeps coordinates exactly.
    back = "mio_%s_back.vtu" % stem
    run("convert", "mio_%s_bin.msh" % stem, back)
    if not np.array_equal(meshio.read(back).points, xyz(ref.points)):
        fail("%s: coordinates differ from meshio's binary .msh" % back)


def main():
    if not PADAPT or not os.access(PADAPT, os.X_OK):
        print("test_meshio: PADAPT must name the padapt executable (got %r)"
              % PADAPT, file=sys.stderr)
        return 1
    print("meshio", meshio.__version__)
    cases = (("a", "box2d", 5, "triangle", "line", None),
             ("b", "box3d", 3, "tetra", "triangle", "line"))

    def one(args):
        try:
            check_case(*args)
        except CliError:
            pass  # already recorded
        except Exception as e:  # a crash of the judge is a failure too
            fail("case %s: %s: %s" % (args[0], type(e).__name__, e))

    # Two threads: the CLI's time is mostly MPI start-up.
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        list(pool.map(one, cases))
    if failures:
        print("test_meshio: %d mismatch(es)" % len(failures), file=sys.stderr)
        return 1
    print("test_meshio: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
