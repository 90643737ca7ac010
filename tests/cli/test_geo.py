#!/usr/bin/python3
"""test_geo.py -- `padapt adapt -geo MODEL`: new boundary vertices on the
CAD model, judged by bench/cad_judge.py from the shapes' closed forms.

Runs, in a scratch working directory (CTest's), with PADAPT = the CLI and
MPIEXEC = mpiexec:
  - the models of cad_judge (a cylinder with a hole, 3D; a plate with a
    disk and an ellipse cut out, 2D) written as .geo, exported as STEP and
    meshed coarsely by the gmsh command line (the 3D one with physical
    groups on some entities: the file lists no curve nor point, and only
    the grouped surfaces);
  - `padapt adapt IN -geo MODEL.step -hsiz H -out OUT.msh` on 1 process
    (the sequential remesher) and 2 (the parallel loop, the pieces'
    remeshers): every boundary vertex of OUT on its entity to 1e-7 of the
    model's size, the model's points kept, the area or volume within the
    polyhedral bound of the result's boundary facets, the classification
    and the physical names kept in OUT;
  - the same input with and without -geo, for contrast: without, the
    boundary stays on the coarse facets (far off the model, the volume
    error more than 5 times the one with -geo);
  - bad inputs, each an error naming the file or the entity and nothing
    written: a MSH 2.2 input (no entities), a model the mesh does not fit
    (scaled by 1.2), a model lacking an entity of the mesh, a model file
    Gmsh cannot read, -geo with -distributed-output.
A padapt built without Gmsh's library is checked for its message only.
Exits 0 on success, 1 naming every failure otherwise.
"""
import os
import subprocess
import sys

SRC = os.environ.get("PADAPT_SRC", os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(SRC, "bench"))
import cad_judge as judge  # noqa: E402

PADAPT = os.environ.get("PADAPT")
MPIEXEC = os.environ.get("MPIEXEC") or "mpiexec"
failures = []

# sizes asked for (the models' size is about 2): a few thousand elements
HSIZ = {"cylhole": 0.07, "plate": 0.03}
TOL = 1e-7  # distance to the model, relative to its size (the issue's)


def fail(msg):
    failures.append(msg)
    print("FAIL: " + msg, file=sys.stderr)


def run(args, mpi=0, expect=0):
    cmd = ([MPIEXEC, "-n", str(mpi)] if mpi else []) + [PADAPT] + [str(a) for a in args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if p.returncode != expect:
        fail("'%s' exited with %d (expected %d): %s" % (
            " ".join(cmd), p.returncode, expect, (p.stderr or p.stdout).strip()[-2000:]))
    return p


def adapt(name, inp, step, out, np_, geo=True):
    args = ["adapt", inp, "-hsiz", HSIZ[name], "-out", out, "-nosol", "-v", "-1"]
    if geo:
        args += ["-geo", step]
    run(args, mpi=np_ if np_ > 1 else 0)
    return os.path.exists(out)


def figures(name, out, ref, label):
    f = judge.judge(out, name, ref)
    print("  %s %s: %d elements, off the model %.2g of its size, volume error "
          "%.2e (polyhedral bound %.2e), %d points kept: %s"
          % (name, label, f["nelem"], f["dist_max"], f["volume_error"],
             f["bound"], f["npoints"], f["points_kept"]))
    return f


def check_model(name, step, inp, full):
    """-geo on 1 and 2 processes from inp, and the contrast from full
    (every element listed: what padapt without -geo reads), with and
    without -geo."""
    ref = judge.read(full)
    ncell0 = len(judge._cells(ref, "tetra" if judge.MODELS[name]["dim"] == 3
                              else "triangle"))
    for np_ in (1, 2):
        out = "%s-geo-np%d.msh" % (name, np_)
        if not adapt(name, inp, step, out, np_):
            continue
        f = figures(name, out, ref, "np %d -geo" % np_)
        if not f["dist_max"] <= TOL:
            fail("%s np %d: a boundary vertex %.3g (of the model's size) off "
                 "its entity" % (name, np_, f["dist_max"]))
        if not f["points_kept"]:
            fail("%s np %d: a point of the model was lost" % (name, np_))
        if f["unclassified"]:
            fail("%s np %d: %d boundary vertices on entities the input does not "
                 "have" % (name, np_, f["unclassified"]))
        if not f["volume_error"] <= f["bound"]:
            fail("%s np %d: volume error %.3g above the polyhedral bound %.3g"
                 % (name, np_, f["volume_error"], f["bound"]))
        if f["nelem"] < 5 * ncell0:
            fail("%s np %d: not refined (%d elements)" % (name, np_, f["nelem"]))
        if judge.MODELS[name]["physical"]:
            names = sorted(judge.read(out).field_data)
            if names != ["hole", "solid", "wall"]:
                fail("%s np %d: physical names %s, expected hole, solid, wall"
                     % (name, np_, names))
    # the same input with and without the model
    fig = {}
    for geo in (True, False):
        out = "%s-full-%s.msh" % (name, "geo" if geo else "plain")
        if adapt(name, full, step, out, 1, geo=geo):
            fig[geo] = figures(name, out, ref, "np 1 %s" % ("-geo" if geo else
                                                           "without -geo"))
    if len(fig) == 2:
        g, p = fig[True], fig[False]
        if not p["dist_max"] > 1e-3:
            fail("%s without -geo: the boundary is on the model (%.3g): the "
                 "contrast shows nothing" % (name, p["dist_max"]))
        if not p["volume_error"] > 5 * g["volume_error"]:
            fail("%s without -geo: volume error %.3g, with -geo %.3g"
                 % (name, p["volume_error"], g["volume_error"]))


def expect_error(args, words, out, mpi=0):
    if os.path.exists(out):
        os.remove(out)
    p = run(args, mpi=mpi, expect=1)
    msg, cmd = p.stderr, " ".join(map(str, args))
    for w in words:
        if w not in msg:
            fail("'%s': the message does not say '%s': %s" % (cmd, w, msg.strip()))
    if os.path.exists(out):
        fail("'%s': %s was written" % (cmd, out))


def bad_inputs(step3, msh3, step2, msh2):
    out = "bad.msh"
    # no entities: MSH 2.2
    judge.gmsh("-3", step3, "-clmax", 0.3, "-format", "msh22", "-o", "in22.msh")
    expect_error(["adapt", "in22.msh", "-geo", step3, "-hsiz", 0.1, "-out", out],
                 ["in22.msh", "MSH 2.2"], out)
    # a model the mesh does not fit: the cylinder and hole 20 % wider
    with open("scaled.geo", "w") as f:
        f.write(judge.MODELS["cylhole"]["geo"].replace(", 0.5};", ", 0.6};")
                .replace(", 0.2};", ", 0.24};"))
    judge.gmsh("-0", "scaled.geo", "-o", "scaled.step")
    expect_error(["adapt", msh3, "-geo", "scaled.step", "-hsiz", 0.1, "-out", out],
                 ["scaled.step", "vertex", "does not match the model"], out)
    # a model that lacks entities of the mesh: the plate without its ellipse
    with open("noellipse.geo", "w") as f:
        f.write(judge.MODELS["plate"]["geo"].replace("Surface{2, 3}", "Surface{2}")
                .replace("Disk(3) = {1.4, 0.5, 0, 0.2, 0.15};\n", ""))
    judge.gmsh("-0", "noellipse.geo", "-o", "noellipse.step")
    expect_error(["adapt", msh2, "-geo", "noellipse.step", "-hsiz", 0.1, "-out", out],
                 ["noellipse.step", "which the geometry does not have"], out)
    # a model file Gmsh cannot read
    with open("broken.step", "w") as f:
        f.write("ISO-10303-21;\nthis is not STEP\n")
    expect_error(["adapt", msh3, "-geo", "broken.step", "-hsiz", 0.1, "-out", out],
                 ["broken.step"], out)
    expect_error(["adapt", msh3, "-geo", "missing.step", "-hsiz", 0.1, "-out", out],
                 ["missing.step"], out)
    # on 2 processes the same message, once
    p = run(["adapt", msh3, "-geo", "broken.step", "-hsiz", 0.1, "-out", out],
            mpi=2, expect=1)
    if p.stderr.count("Gmsh cannot read") != 1 or os.path.exists(out):
        fail("2 processes, unreadable model: %s" % p.stderr.strip())
    # a distributed set cannot keep the entities
    expect_error(["adapt", msh3, "-geo", step3, "-hsiz", 0.1, "-out", "set.meshb",
                  "-distributed-output"], ["-geo", "-distributed-output"], "set.meshb")


def main():
    if not PADAPT:
        print("test_geo: set PADAPT to the padapt CLI", file=sys.stderr)
        return 1
    # a padapt without Gmsh's library says so, and that is all it can do
    p = subprocess.run([PADAPT, "adapt", "none.msh", "-geo", "none.step", "-hsiz", "1"],
                       capture_output=True, text=True)
    if "built without Gmsh's library" in p.stderr:
        print("test_geo: padapt was built without Gmsh's library: -geo says so")
        return 0 if p.returncode == 1 else 1
    step3, msh3 = judge.make("cylhole", ".", 0.3, physical=True)
    _, full3 = judge.make("cylhole", ".", 0.3)
    step2, msh2 = judge.make("plate", ".", 0.3)
    check_model("cylhole", step3, msh3, full3)
    check_model("plate", step2, msh2, msh2)
    bad_inputs(step3, msh3, step2, msh2)
    if failures:
        print("test_geo: %d failure(s)" % len(failures), file=sys.stderr)
        return 1
    print("test_geo: ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
