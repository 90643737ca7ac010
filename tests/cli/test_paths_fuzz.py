#!/usr/bin/python3
"""test_paths_fuzz.py -- a seeded random search over the ways to spell one
file, for outputs that are inputs (docs/guide/outputs.md, "Paths that are
refused"). Each run picks a command, one of its output options and one of
its input files (or another of its outputs), and spells the path with a
random chain of ./, //, dir/.., a symbolic link to a directory, an
absolute path, or a hard link (hard.mesh, m.svg). padapt must refuse it before any work:
status 1, a message naming the clash, every file of the directory as it
was. Then the control runs: the same commands whose outputs share an
input's name in another directory, or reach a fresh file through those
spellings, must succeed (the check sees files, not names).

The runs depend only on SEED (below) and the number of runs; a failure
prints the command line, which replays it in the directory of the test.
"""
import hashlib
import os
import random
import shutil
import subprocess
import sys

PADAPT = os.environ["PADAPT"]
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
SEED = 35  # the issue this guards
NRUNS = 50  # refused runs: a start of padapt each (refused before any work)
NCONTROL = 10  # accepted runs: each writes its outputs
fails = []


def run(args, np=0):
    cmd = ([MPIEXEC, "-n", str(np)] if np else []) + [PADAPT] + args
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                       text=True, timeout=120)
    return r.returncode, r.stderr


def snapshot():
    """Every file below the working directory (links as their targets'
    names) with a digest of its bytes."""
    out = {}
    for root, dirs, files in os.walk(".", followlinks=False):
        for n in files + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            p = os.path.join(root, n)
            if os.path.islink(p):
                out[p] = "-> " + os.readlink(p)
            else:
                with open(p, "rb") as f:
                    out[p] = hashlib.sha1(f.read()).hexdigest()
    return out


def spell(name, rng):
    """name (a file of the working directory) spelt another way: a random
    chain of the rewrites below, at least one, then at times absolute."""
    p = name
    for _ in range(rng.randint(1, 3)):
        k = rng.randrange(5)
        if k == 0:
            p = "./" + p
        elif k == 1:
            p = "sub/../" + p
        elif k == 2:
            p = "ld/" + p  # ld -> .
        elif k == 3:
            p = "sub/up/" + p  # sub/up -> ..
        else:
            p = p.replace("/", "//", 1) if "/" in p else ".//" + p
    if rng.random() < 0.25:
        p = os.path.join(os.getcwd(), p)
    return p


# command name -> (argument template, inputs, outputs): {IN}, {MET}... are
# filled with paths; inputs and outputs name the template's slots
COMMANDS = {
    "adapt": (["adapt", "{IN}", "-met", "{MET}", "-out", "{OUT}", "-json",
               "{JSON}"], ["IN", "MET"], ["OUT", "JSON"]),
    "adapt-sol": (["adapt", "{IN}", "-met", "{MET}", "-out", "{OUT}",
                   "-outsol", "{SOL}"], ["IN", "MET"], ["OUT", "SOL"]),
    "adapt-field": (["adapt", "{IN}", "-hsiz", "0.3", "-field", "{FIELD}",
                     "-out", "{OUT}", "-outfield", "{FOUT}"],
                    ["IN", "FIELD"], ["OUT", "FOUT"]),
    "stats": (["stats", "{IN}", "-met", "{MET}", "-json", "{JSON}", "-svg",
               "{SVG}"], ["IN", "MET"], ["JSON", "SVG"]),
    "convert": (["convert", "{IN}", "{OUT}", "-met", "{MET}"], ["IN", "MET"],
                ["OUT"]),
    "metric": (["metric", "intersect", "{IN}", "{MET}", "{FIELD}", "{SOLOUT}"],
               ["IN", "MET", "FIELD"], ["SOLOUT"]),
    "plot": (["plot", "{IN}", "{SVG}", "-met", "{MET}"], ["IN", "MET"],
             ["SVG"]),
}
INPUTS = {"IN": "sq.mesh", "MET": "m.sol", "FIELD": "f.sol"}
# fresh output names by slot, with the extension each option wants
FRESH = {"OUT": "o.mesh", "JSON": "r.json", "SOL": "o2.sol", "FOUT": "fo.sol",
         "SVG": "p.svg", "SOLOUT": "i.sol"}


def fill(template, paths):
    return [a.format(**paths) if "{" in a else a for a in template]


def ext(name):
    return name.rsplit(".", 1)[1]


def clashes(cmd):
    """The (output slot, file name, message) a run of cmd may pick: an
    output onto an input (of an extension the option takes: -json takes
    any), onto a file derived from another output, or onto another
    output."""
    template, ins, outs = COMMANDS[cmd]
    is_in, same = "refusing to overwrite an input", "are the same file"
    names = [INPUTS[i] for i in ins] + (["hard.mesh"] if "IN" in ins else []) \
        + (["m.svg"] if "MET" in ins else [])  # hard links to inputs
    out = []
    for slot in outs:
        out += [(slot, n, is_in) for n in names
                if slot == "JSON" or ext(n) == ext(FRESH[slot])]
        if slot == "JSON":
            out += [(slot, FRESH[o], same) for o in outs if o != slot]
    if cmd == "adapt":  # OUT.sol, the metric written beside OUT
        out += [("OUT", "m.mesh", is_in), ("JSON", "o.sol", same)]
    return out


def main():
    wd = "paths"
    shutil.rmtree(wd, ignore_errors=True)
    os.mkdir(wd)
    os.chdir(wd)
    if run(["generate", "box2d", "4", "sq.mesh"])[0] or \
       run(["metric", "uniform:0.3", "sq.mesh", "m.sol"])[0]:
        sys.exit("FAIL: the input files")
    shutil.copy("m.sol", "f.sol")
    os.mkdir("sub")
    os.symlink(".", "ld")
    os.symlink("..", "sub/up")
    os.link("sq.mesh", "hard.mesh")
    os.link("m.sol", "m.svg")
    rng = random.Random(SEED)
    before = snapshot()
    names = sorted(COMMANDS)
    for it in range(NRUNS):
        cmd = rng.choice(names)
        slot, name, want = rng.choice(clashes(cmd))
        paths = dict(INPUTS)
        paths.update(FRESH)
        paths[slot] = spell(name, rng)
        np = rng.choice([0, 0, 0, 2])
        args = fill(COMMANDS[cmd][0], paths)
        rc, err = run(args, np)
        after = snapshot()
        line = "%s%s" % ("mpiexec -n %d " % np if np else "", " ".join(args))
        if rc != 1 or want not in err:
            fails.append(line)
            print("FAIL %s: status %d: %s" % (line, rc, err.strip()[:300]))
        elif after != before:
            fails.append(line)
            print("FAIL %s: files changed: %s" % (line, sorted(
                set(after.items()) ^ set(before.items()))))
        else:
            print("ok   %s" % line)
        before = after
    # controls: an input's name in another directory, fresh files through
    # the same spellings
    for it in range(NCONTROL):
        cmd = rng.choice(names)
        template, ins, outs = COMMANDS[cmd]
        paths = dict(INPUTS)
        for o in outs:
            same = [INPUTS[i] for i in ins if ext(INPUTS[i]) == ext(FRESH[o])]
            if same and rng.random() < 0.5:
                paths[o] = "sub/" + rng.choice(same)
            else:
                paths[o] = spell("new%d%s.%s" % (it, o, ext(FRESH[o])), rng)
        args = fill(template, paths)
        rc, err = run(args)
        line = " ".join(args)
        missing = [paths[o] for o in outs if not os.path.exists(paths[o])]
        if rc != 0 or missing:
            fails.append(line)
            print("FAIL %s: status %d, missing %s: %s" % (line, rc, missing,
                                                           err.strip()[:300]))
        else:
            print("ok   %s (written)" % line)
        for p in set(snapshot()) - set(before):  # what the run wrote
            os.remove(p)
    print("%d runs, %d failed" % (NRUNS + NCONTROL, len(fails)))
    sys.exit(1 if fails else 0)


main()
