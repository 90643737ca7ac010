#!/usr/bin/env python3
"""Regenerate the malformed binary Gmsh files of tests/data/bad (gmsh_binary_*).

Each is a binary MSH 4.1 file (little-endian, data size 8) of the unit square
split in two triangles, broken in one way. The ASCII gmsh_*.msh files are
written by hand; gmsh.expected lists, for every file, a fragment that the
error message must contain. Run from anywhere: python3 make_gmsh_bad.py
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def i32(*v):
    return struct.pack("<%di" % len(v), *v)


def u64(*v):
    return struct.pack("<%dQ" % len(v), *v)


def f64(*v):
    return struct.pack("<%dd" % len(v), *v)


def square(nodes_count=4, marker=1, coords=None, tri2=(1, 3, 4),
           before_nodes=b""):
    """A binary MSH 4.1 file; the keyword arguments break it."""
    if coords is None:
        coords = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]
    out = b"$MeshFormat\n4.1 1 8\n" + i32(marker) + b"\n$EndMeshFormat\n"
    out += b"$Entities\n" + u64(0, 0, 1, 0)
    out += i32(1) + f64(0, 0, 0, 1, 1, 0) + u64(1) + i32(1) + u64(0)
    out += b"\n$EndEntities\n"
    out += before_nodes
    out += b"$Nodes\n" + u64(1, nodes_count, 1, 4)
    out += i32(2, 1, 0) + u64(4) + u64(1, 2, 3, 4) + f64(*coords)
    out += b"\n$EndNodes\n"
    out += b"$Elements\n" + u64(1, 2, 1, 2)
    out += i32(2, 1, 2) + u64(2) + u64(1, 1, 2, 3) + u64(2, *tri2)
    out += b"\n$EndElements\n"
    return out


def main():
    files = {}
    good = square()
    cut = good.index(b"$Nodes\n") + len(b"$Nodes\n") + 32 + 20 + 32 + 40
    files["gmsh_binary_truncated.msh"] = good[:cut]
    files["gmsh_binary_huge_count.msh"] = square(nodes_count=10**12)
    files["gmsh_binary_unknown_node.msh"] = square(tri2=(1, 3, 77))
    files["gmsh_binary_endianness.msh"] = square(marker=0x01000000)
    coords = [0, 0, 0, 1, 0, 0, 1, math.nan, 0, 0, 1, 0]
    files["gmsh_binary_nan.msh"] = square(coords=coords)
    periodic = b"$Periodic\n" + u64(0) + b"\n$EndPeriodic\n"
    files["gmsh_binary_periodic.msh"] = square(before_nodes=periodic)
    for name, data in files.items():
        with open(os.path.join(HERE, name), "wb") as f:
            f.write(data)
    print("wrote", len(files), "files in", HERE)


if __name__ == "__main__":
    main()
