#!/usr/bin/env python3
"""The three FreeFem++ loops of examples/freefem, small versions
(run.sh OUTDIR CASE small), judged on what they produce:

- CASE.json has exactly the issue's schema, and the SVG parses with one
  polyline per series;
- the uniform errors decrease with the mesh size, the adapted ones from an
  iteration (a fixed-point pass) to the next;
- the adapted meshes read back: padapt stats finds the vertex counts
  FreeFem++ reported for them;
- the carried solution matches: padapt's carried field differs from
  FreeFem++'s interpolation of the previous solution by less than that
  solution's own error (steady), and the fixed-point change of every window
  falls from a pass to the next (unsteady);
- the adapted error beats the uniform one at equal vertices (log-log
  interpolation of the uniform series), which holds at these sizes.
"""
import glob
import json
import math
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

PADAPT = os.environ["PADAPT"]
SRC = os.environ["PADAPT_SRC"]
RUN = os.path.join(SRC, "examples", "freefem", "run.sh")
fails = 0


def check(cond, what):
    global fails
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        fails += 1


def interp_uniform(uniform, v):
    """Log-log interpolation of the uniform error at v vertices (None outside
    the range of the series)."""
    pts = sorted((p["vertices"], p["error"]) for p in uniform)
    for (va, ea), (vb, eb) in zip(pts, pts[1:]):
        if va <= v <= vb:
            t = math.log(v / va) / math.log(vb / va)
            return math.exp((1 - t) * math.log(ea) + t * math.log(eb))
    return None


def stats_vertices(path):
    out = subprocess.run([PADAPT, "stats", path], capture_output=True,
                         text=True).stdout
    m = re.search(r"^\s*vertices\s+(\d+)", out, re.M)
    return int(m.group(1)) if m else None


def run(case):
    env = dict(os.environ, NP="2")
    r = subprocess.run(["bash", RUN, "out", case, "small"], env=env,
                       capture_output=True, text=True)
    print(r.stdout, end="")
    check(r.returncode == 0, "%s: run.sh exits 0%s" % (case, "" if r.returncode == 0
                                                       else ": " + r.stderr[-2000:]))
    if r.returncode:
        return None, r.stdout
    with open("out/%s.json" % case) as f:
        data = json.load(f)
    check(set(data) == {"case", "adapted", "uniform"} and data["case"] == case,
          "%s: keys case, adapted, uniform" % case)
    check(all(set(p) == {"vertices", "elements", "error", "seconds"}
              for p in data["adapted"]) and data["adapted"],
          "%s: adapted entries: vertices, elements, error, seconds" % case)
    check(all(set(p) == {"vertices", "elements", "error"}
              for p in data["uniform"]) and len(data["uniform"]) >= 2,
          "%s: uniform entries: vertices, elements, error" % case)
    svg = ET.parse("out/%s.svg" % case).getroot()
    lines = [e for e in svg.iter() if e.tag.endswith("polyline")]
    check(len(lines) == 2, "%s: the SVG has the two series" % case)
    u = sorted(data["uniform"], key=lambda p: p["vertices"])
    check(all(a["error"] > b["error"] for a, b in zip(u, u[1:])),
          "%s: uniform errors decrease: %s" % (case, [p["error"] for p in u]))
    return data, r.stdout


def steady(case):
    data, log = run(case)
    if not data:
        return
    a = data["adapted"]
    check(all(x["error"] > y["error"] for x, y in zip(a, a[1:])),
          "%s: adapted errors decrease: %s" % (case, [p["error"] for p in a]))
    # carried vs interpolated, against the error of the solution carried
    carried = [float(m.group(1)) for m in re.finditer(
        r"carried vs interpolated \(L2, max\): (\S+)", log)]
    start = re.search(r"^start n=\d+: RESULT \S+ \S+ (\S+)", log, re.M)
    prev_err = [float(start.group(1)) if start else 0] + [p["error"] for p in a[:-1]]
    check(len(carried) == len(a), "%s: a carried solution per iteration" % case)
    for k, (c, e) in enumerate(zip(carried, prev_err)):
        check(c < e, "%s: iteration %d: carried differs from FreeFem++'s "
              "interpolation by %.3g (L2) < the error %.3g of the solution "
              "carried" % (case, k + 1, c, e))
    for k, p in enumerate(a):
        v = stats_vertices("out/%s/m%d.mesh" % (case, k + 1))
        check(v == p["vertices"], "%s: m%d.mesh read back: padapt %s, FreeFem++ %d "
              "vertices" % (case, k + 1, v, p["vertices"]))
    last = a[-1]
    ue = interp_uniform(data["uniform"], last["vertices"])
    check(ue is not None and last["error"] < ue,
          "%s: adapted error %.3g < uniform %s at %d vertices"
          % (case, last["error"], "%.3g" % ue if ue else "?", last["vertices"]))


def unsteady(case):
    data, log = run(case)
    if not data:
        return
    passes = [(float(m.group(1)), float(m.group(2)), m.group(3).split())
              for m in re.finditer(r"pass \d+: RESULT (\S+) \S+ (\S+); fixed-point "
                                   r"change per window: (.*)$", log, re.M)]
    check(len(passes) >= 2, "%s: %d fixed-point passes" % (case, len(passes)))
    errs = [p[1] for p in passes]
    check(all(x > y for x, y in zip(errs, errs[1:])),
          "%s: the final-time error falls pass after pass: %s" % (case, errs))
    ch = [[float(c) for c in p[2]] for p in passes]
    check(all(len(c) == len(ch[0]) and all(b < a for a, b in zip(x, c))
              for x, c in zip(ch, ch[1:])),
          "%s: every window's fixed-point change falls: %s" % (case, ch))
    meshes = sorted(glob.glob("out/%s/c*.p%d.[0-9]*.mesh" % (case, len(passes))))
    check(len(meshes) == (len(ch[0]) if ch else -1),
          "%s: a mesh per window in the last pass" % case)
    for path in meshes:
        check(stats_vertices(path) is not None, "%s: %s read back" % (case, path))
    last = data["adapted"][-1]
    ue = interp_uniform(data["uniform"], last["vertices"])
    check(ue is not None and last["error"] < ue,
          "%s: adapted final-time error %.3g < uniform %s at the same space-time "
          "cost (%d vertices per step)" % (case, last["error"],
                                            "%.3g" % ue if ue else "?",
                                            last["vertices"]))


steady("steady2d")
steady("steady3d")
unsteady("unsteady2d")
if fails:
    print("%d failure(s)" % fails)
    sys.exit(1)
