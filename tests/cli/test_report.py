#!/usr/bin/python3
"""test_report.py -- `padapt adapt` reports against the metric the user gave.

In a scratch directory (CTest's), with PADAPT = the CLI:
  - a field that violates the gradation bound (shell:0.1 on box2d 20: normal
    sizes growing 0.49 per unit length, the bound is ln 1.3 = 0.26): the
    JSON's statistics are in the given metric and miss the target, the metric
    used (after the gradation) meets it, "limited_by" names the gradation,
    the outcome is "target missed", the text report prints both and the
    process exits 0 with a warning; the same at 2 processes;
  - -hgrad -1: nothing changes the metric, the two sets of figures agree,
    the outcome is "success";
  - -hmin above the smallest size: "limited_by" names hmin;
  - -hgradreq is accepted, -hgrad needs a number;
  - the UGAWG polar-2 field on box2d 40, whose sizes grow slowly enough
    though its frame turns, is left unchanged by the gradation;
  - the remeshing work: "remesh_cpu_s" (the remesher's thread CPU time) is
    positive and no more than the remesher's wall-clock time, sequential
    ("time_s") and at 2 processes ("remesh_busy_s", summed over the ranks,
    also per iteration), and the text reports print it; at 2 processes the
    measurement of the result ("steps_s" "measure") is part of "time_s",
    and the remesher's operations ("nsplit", "ncollapse", "nswap",
    "nmove") are the sums of the iterations' and printed.
Exits 0 when every check passes, 1 naming each failure.
"""
import json
import os
import subprocess
import sys

PADAPT = os.environ.get("PADAPT")
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def run(args, np=1):
    cmd = [PADAPT] + args
    if np > 1:
        cmd = [MPIEXEC, "-n", str(np)] + cmd
    return subprocess.run(cmd, capture_output=True, text=True)


def adapt(tag, extra, np=1, field="shell:0.1", dim=2, n=20):
    mesh, sol = "%s.mesh" % tag, "%s.sol" % tag
    run(["generate", "box%dd" % dim, str(n), mesh])
    run(["metric", field, mesh, sol])
    r = run(["adapt", mesh, "-met", sol, "-out", tag + "-out.mesh", "-nosol",
             "-json", tag + ".json"] + extra, np)
    rep = json.load(open(tag + ".json")) if r.returncode == 0 else {}
    return r, rep


def check_work(tag, np, r, rep):
    """The remeshing work figures of a report: CPU seconds within wall."""
    cpu = rep.get("remesh_cpu_s", -1)
    wall = rep["time_s"] if np == 1 else rep.get("remesh_busy_s", -1)
    check(0 < cpu <= wall * 1.02 + 0.005,
          "%s: remesher CPU %.4f s in (0, wall %.4f s]" % (tag, cpu, wall))
    if np > 1:
        meas = rep.get("steps_s", {}).get("measure", -1)
        check(0 < meas < rep["time_s"],
              "%s: measuring the result took %.4f s of %.4f s"
              % (tag, meas, rep["time_s"]))
        iters = rep.get("iteration_detail", [])
        total = sum(it.get("remesh_cpu_s", -1) for it in iters)
        check(iters and abs(total - cpu) <= 1e-6 * max(1, cpu),
              "%s: the iterations' CPU sums to the total (%.6f, %.6f)"
              % (tag, total, cpu))
        for op in ("nsplit", "ncollapse", "nswap", "nmove"):
            n = rep.get(op, -1)
            parts = sum(it.get(op, -1) for it in iters)
            check(n >= 0 and parts == n,
                  "%s: %s %d, the iterations' sum %d" % (tag, op, n, parts))
        check(rep.get("nsplit", 0) > 0, "%s: the pieces split edges" % tag)
        check("remesher operations" in r.stdout,
              "%s: the text report prints the operations" % tag)
    check(("remesher CPU" if np == 1 else "CPU") in r.stdout,
          "%s: the text report prints the CPU time" % tag)


def main():
    if not PADAPT:
        print("test_report: PADAPT is not set", file=sys.stderr)
        return 1
    for np in (1, 2):
        tag = "graded-np%d" % np
        r, rep = adapt(tag, [], np)
        check(r.returncode == 0, "%s: exit 0 (%d)" % (tag, r.returncode))
        if not rep:
            continue
        used = rep["metric_used"]
        check(used["changed"] is True, "%s: the gradation changed the metric" % tag)
        check(used["edge_in_range"] >= 0.9,
              "%s: the metric used is met (%.3f)" % (tag, used["edge_in_range"]))
        check(rep["edge_in_range"] < 0.9,
              "%s: the given metric is not (%.3f)" % (tag, rep["edge_in_range"]))
        check(rep["outcome"] == "target missed" and rep["target_met"] is False,
              "%s: outcome %s" % (tag, rep["outcome"]))
        check(rep["limited_by"] == ["gradation"],
              "%s: limited by %s" % (tag, rep["limited_by"]))
        check("IN THE METRIC USED" in r.stdout and "limited by" in r.stdout,
              "%s: the text report gives both and the cause" % tag)
        check("target missed" in r.stderr, "%s: warning on stderr" % tag)
        check_work(tag, np, r, rep)

    r, rep = adapt("nograd", ["-hgrad", "-1"])
    check(r.returncode == 0 and rep.get("outcome") == "success",
          "-hgrad -1: success (%s)" % rep.get("outcome"))
    if rep:
        used = rep["metric_used"]
        check(used["changed"] is False, "-hgrad -1: the metric is the given one")
        # metric_used gives 6 decimals
        check(abs(used["edge_in_range"] - rep["edge_in_range"]) < 1e-6,
              "-hgrad -1: the two sets of figures agree")
        check("IN THE METRIC USED" not in r.stdout,
              "-hgrad -1: no second set printed")

    r, rep = adapt("ugawg", [], field="ugawg-polar2", n=40)
    if rep:
        check(rep["metric_used"]["changed"] is False,
              "ugawg-polar2 on box2d 40: the gradation leaves it unchanged")

    r, rep = adapt("hmin", ["-hmin", "0.02", "-hgrad", "-1"])
    check("hmin" in rep.get("limited_by", []),
          "-hmin 0.02: limited by %s" % rep.get("limited_by"))

    r, rep = adapt("req", ["-hgradreq", "1.5"])
    check(r.returncode == 0, "-hgradreq accepted")
    r = run(["adapt", "graded-np1.mesh", "-met", "graded-np1.sol", "-out",
             "x.mesh", "-hgrad", "abc"])
    check(r.returncode != 0 and "hgrad" in r.stderr, "-hgrad abc refused")
    for f in failures:
        print("FAIL: " + f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
