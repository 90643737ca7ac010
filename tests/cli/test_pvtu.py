#!/usr/bin/python3
"""test_pvtu.py -- the ParaView files of a distributed set, judged by meshio
and the XML parser.

A 3-process adaptation written with -distributed-output; then:
  - OUT.pvtu parses, lists one piece per rank, and declares every point and
    cell array each piece holds, with the same type and component count;
  - each piece reads in meshio with elements, boundary triangles and
    feature edges; "rank" is the piece's rank on every cell;
  - the points whose vtkGhostType is 0 carry distinct global ids ("gid"),
    as many as the set's vertices (padapt stats), and every ghost point's
    gid is owned by another piece; the elements add up to the set's count
    and their gids are distinct;
  - "metric" and "size" are 3 x 3 tensors with S M S = I;
  - the active cell scalars are "quality" (as the README says), and every
    boundary triangle and feature edge is in one piece only: as many as
    the manifest counts, with distinct gids (the edges on the interfaces
    between ranks were in both pieces).
"""
import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import meshio
import numpy as np

PADAPT = os.environ["PADAPT"]
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
NP = 3
fails = []


def fail(msg):
    fails.append(msg)
    print("FAIL " + msg)


def run(*args, mpi=False):
    cmd = ([MPIEXEC, "-n", str(NP)] if mpi else []) + [PADAPT] + list(args)
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if p.returncode:
        print(p.stdout + p.stderr)
        sys.exit("'%s' exited with %d" % (" ".join(args), p.returncode))
    return p.stdout


run("generate", "box3d", "4", "in.mesh")
run("metric", "shell", "in.mesh", "in.sol")
for f in os.listdir("."):
    if f.startswith("set."):
        os.remove(f)
run("adapt", "in.mesh", "-met", "in.sol", "-out", "set.meshb",
    "-distributed-output", mpi=True)
run("stats", "set.meshb", "-json", "s.json")
with open("s.json") as f:
    stats = json.load(f)

root = ET.parse("set.pvtu").getroot()
grid = root.find("PUnstructuredGrid")
pieces = [p.get("Source") for p in grid.findall("Piece")]
if pieces != ["set.%d.vtu" % r for r in range(NP)]:
    fail("set.pvtu lists %s" % pieces)
declared = {}
for kind in ("PPointData", "PCellData"):
    for a in grid.find(kind).findall("PDataArray"):
        declared[(kind[1:], a.get("Name"))] = (a.get("type"),
                                               a.get("NumberOfComponents", "1"))

if grid.find("PCellData").get("Scalars") != "quality":
    fail("set.pvtu: active cell scalars '%s', not 'quality'" %
         grid.find("PCellData").get("Scalars"))
with open("set.manifest") as f:
    glob = [l.split() for l in f if l.startswith("global ")][0]
nglob = {"triangle": int(glob[glob.index("boundary") + 1]),
         "line": int(glob[glob.index("edges") + 1])}
cell_gids = {"triangle": [], "line": []}

owned, elem_gids, nelem = [], [], 0
ghost_gids = []
for r in range(NP):
    path = "set.%d.vtu" % r
    with open(path, "rb") as f:  # the XML head (the appended data is raw)
        head = f.read().split(b"<AppendedData")[0]
    piece = ET.fromstring(head + b"</VTKFile>").find("UnstructuredGrid/Piece")
    for kind in ("PointData", "CellData"):
        for a in piece.find(kind).findall("DataArray"):
            key = (kind, a.get("Name"))
            got = (a.get("type"), a.get("NumberOfComponents", "1"))
            if declared.get(key) != got:
                fail("%s: %s '%s' %s, set.pvtu declares %s" %
                     (path, kind, key[1], got, declared.get(key)))
    m = meshio.read(path)
    types = {c.type for c in m.cells}
    if types != {"tetra", "triangle", "line"}:
        fail("%s: cell types %s" % (path, sorted(types)))
    for arr in m.cell_data["rank"]:
        if np.any(arr != r):
            fail("%s: rank data %s" % (path, np.unique(arr)))
    gh, gid = m.point_data["vtkGhostType"], m.point_data["gid"]
    owned += gid[gh == 0].tolist()
    ghost_gids += gid[gh != 0].tolist()
    for c, g in zip(m.cells, m.cell_data["gid"]):
        if c.type == "tetra":
            elem_gids += g.tolist()
            nelem += len(c.data)
        else:
            cell_gids[c.type] += g.tolist()
    met = m.point_data["metric"].reshape(-1, 3, 3)
    size = m.point_data["size"].reshape(-1, 3, 3)
    if not np.allclose(size @ met @ size, np.eye(3)[None], atol=1e-9):
        fail("%s: S M S != I" % path)

if len(owned) != stats["vertices"] or len(set(owned)) != len(owned):
    fail("owned points: %d (%d distinct), the set has %d vertices" %
         (len(owned), len(set(owned)), stats["vertices"]))
if not set(ghost_gids) <= set(owned):
    fail("ghost points whose gid no piece owns")
if nelem != stats["elements"] or len(set(elem_gids)) != nelem:
    fail("elements: %d (%d distinct gids), the set has %d" %
         (nelem, len(set(elem_gids)), stats["elements"]))
for t, g in cell_gids.items():
    if len(g) != nglob[t] or len(set(g)) != len(g):
        fail("%s cells: %d in the pieces (%d distinct gids), the set has %d" %
             (t, len(g), len(set(g)), nglob[t]))
print("%d pieces, %d owned points, %d elements" % (NP, len(owned), nelem))
if fails:
    sys.exit("%d check(s) failed" % len(fails))
print("all checks passed")
