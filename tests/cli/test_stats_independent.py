#!/usr/bin/python3
"""test_stats_independent.py -- an independent judge of `padapt stats`.

For each case it runs
    $PADAPT generate box2d|box3d N m.mesh
    $PADAPT metric FIELD m.mesh m.sol            (unless no metric)
    $PADAPT stats m.mesh [-met m.sol] -json s.json
then parses the Medit .mesh/.sol ASCII files itself and recomputes with numpy:
counts, volume, inverted elements, unique edges and their lengths in the
metric (geometric formula L = (la - lb) / ln(la / lb), la = sqrt(e^T Ma e),
the mean when |la - lb| < 1e-3 max), bins and in-range fraction, element
qualities in Mmg's normalisation (arithmetic mean of the vertex metrics), and
compares with the JSON (relative 1e-9; bins exactly, up to values that sit
within rounding of a bin bound). It also checks the metric values written by
`padapt metric` against the field definitions documented in
src/metric/analytic.c.

Exits 0 on success, 1 with a message naming every differing key otherwise.
Run by CTest with PADAPT = path of the CLI, in a scratch working directory.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np

RTOL = 1e-9
EDGE_BOUNDS = [0.3, 0.6, 0.7071, 0.9, 1.3, 1.4142, 2.0, 5.0]
QUAL_BOUNDS = [0.2, 0.4, 0.6, 0.8]

# entries per line (integers/reals) of the Medit keywords we may meet
MEDIT_SIZES = {
    "edges": 3, "triangles": 4, "quadrilaterals": 5, "tetrahedra": 5,
    "prisms": 7, "hexahedra": 9, "corners": 1, "ridges": 1,
    "requiredvertices": 1, "requirededges": 1, "requiredtriangles": 1,
    "requiredquadrilaterals": 1, "requiredtetrahedra": 1,
    "normalatvertices": 2, "tangentatvertices": 2,
}

failures = []


def fail(msg):
    failures.append(msg)
    print("MISMATCH: " + msg, file=sys.stderr)


def tokens_of(path):
    with open(path) as f:
        lines = [ln.split("#", 1)[0] for ln in f]
    return " ".join(lines).split()


def read_medit(path):
    """Return dim, coords (nv x dim), elements (ne x dim+1, 0-based),
    number of boundary entities."""
    tok = tokens_of(path)
    i, dim = 0, None
    coords, elems, nbdry = None, None, 0
    sections = {}
    while i < len(tok):
        key = tok[i].lower()
        i += 1
        if key == "meshversionformatted":
            i += 1
        elif key == "dimension":
            dim = int(tok[i])
            i += 1
        elif key == "end":
            break
        elif key == "vertices":
            n = int(tok[i])
            i += 1
            vals = np.array(tok[i:i + n * (dim + 1)], dtype=float)
            i += n * (dim + 1)
            coords = vals.reshape(n, dim + 1)[:, :dim]
        elif key in ("normals", "tangents"):
            n = int(tok[i])
            i += 1 + n * dim
        elif key in MEDIT_SIZES:
            n = int(tok[i])
            w = MEDIT_SIZES[key]
            vals = np.array(tok[i + 1:i + 1 + n * w], dtype=np.int64)
            i += 1 + n * w
            sections[key] = vals.reshape(n, w)
        else:
            raise ValueError("%s: unexpected keyword %r" % (path, tok[i - 1]))
    if dim not in (2, 3) or coords is None:
        raise ValueError("%s: no Dimension or no Vertices" % path)
    ekey = "triangles" if dim == 2 else "tetrahedra"
    bkey = "edges" if dim == 2 else "triangles"
    elems = sections.get(ekey, np.zeros((0, dim + 2), dtype=np.int64))
    elems = elems[:, :dim + 1] - 1
    if bkey in sections:
        nbdry = len(sections[bkey])
    return dim, coords, elems, nbdry


def read_sol(path, dim):
    """Return the first SolAtVertices field: (type, values nv x ncomp)."""
    tok = tokens_of(path)
    i = 0
    while i < len(tok):
        key = tok[i].lower()
        i += 1
        if key == "meshversionformatted":
            i += 1
        elif key == "dimension":
            if int(tok[i]) != dim:
                raise ValueError("%s: dimension %s, mesh has %d" % (path, tok[i], dim))
            i += 1
        elif key == "solatvertices":
            n = int(tok[i])
            nf = int(tok[i + 1])
            types = [int(t) for t in tok[i + 2:i + 2 + nf]]
            i += 2 + nf
            sizes = {1: 1, 2: dim, 3: dim * (dim + 1) // 2}
            ncomp = [sizes[t] for t in types]
            vals = np.array(tok[i:i + n * sum(ncomp)], dtype=float)
            vals = vals.reshape(n, sum(ncomp))
            return types[0], vals[:, :ncomp[0]]
        else:
            raise ValueError("%s: unexpected keyword %r" % (path, tok[i - 1]))
    raise ValueError("%s: no SolAtVertices" % path)


def full_tensors(dim, kind, vals):
    """nv x dim x dim metric tensors from sizes (kind 1) or Medit tensors."""
    nv = len(vals)
    M = np.zeros((nv, dim, dim))
    if kind == 1:
        for k in range(dim):
            M[:, k, k] = 1.0 / vals[:, 0] ** 2
        return M
    # storage m11 m12 m22 [m13 m23 m33]
    slots = {(0, 0): 0, (0, 1): 1, (1, 1): 2, (0, 2): 3, (1, 2): 4, (2, 2): 5}
    for (a, b), s in slots.items():
        if a < dim and b < dim:
            M[:, a, b] = vals[:, s]
            M[:, b, a] = vals[:, s]
    return M


def expected_field(spec, dim, X):
    """The documented analytic fields (src/metric/analytic.c)."""
    name, _, hs = spec.partition(":")
    h = float(hs) if hs else 0.1
    nv = len(X)

    def ramp(h0, d, dist):
        return np.where(d >= dist, h, h0 + (h - h0) * np.minimum(d, dist) / dist)

    if name == "uniform":
        return 1, np.full((nv, 1), h)
    c = np.full(dim, 0.5)
    r = np.linalg.norm(X - c, axis=1)
    d = np.abs(r - 0.3)
    if name == "iso-shell":
        return 1, ramp(h / 10, d, 0.2).reshape(nv, 1)
    M = np.zeros((nv, dim, dim))
    if name == "layer":
        hn = ramp(h / 100, np.abs(X[:, 0] - 0.5), 0.25)
        M[:, 0, 0] = 1 / hn ** 2
        for k in range(1, dim):
            M[:, k, k] = 1 / h ** 2
    elif name == "shell":
        hn = ramp(h / 50, d, 0.2)
        with np.errstate(invalid="ignore", divide="ignore"):
            n = (X - c) / r[:, None]
        n[r == 0] = 0
        nn = np.einsum("ni,nj->nij", n, n)
        eye = np.broadcast_to(np.eye(dim), (nv, dim, dim))
        M = nn / hn[:, None, None] ** 2 + (eye - nn) / h ** 2
        far = d >= 0.2
        M[far] = np.eye(dim) / h ** 2
    else:
        raise ValueError("unknown field " + spec)
    return 3, M


def log_mean(la, lb):
    mx = np.maximum(la, lb)
    close = ~(np.abs(la - lb) >= 1e-3 * mx)
    with np.errstate(invalid="ignore", divide="ignore"):
        lm = (la - lb) / np.log(la / lb)
    return np.where(close, 0.5 * (la + lb), lm)


def simplex_volumes(dim, X, E):
    P = X[E]  # ne x (dim+1) x dim
    U = P[:, 1:, :] - P[:, :1, :]
    if dim == 2:
        return 0.5 * (U[:, 0, 0] * U[:, 1, 1] - U[:, 0, 1] * U[:, 1, 0])
    return np.linalg.det(U) / 6.0


def hist(values, bounds):
    return np.searchsorted(np.array(bounds), values, side="right")


def ambiguous(values, bounds):
    """How many values lie within rounding of a bin bound."""
    if len(values) == 0:
        return 0
    b = np.array(bounds)
    return int(np.sum(np.min(np.abs(values[:, None] - b[None, :]) / b[None, :],
                             axis=1) <= 1e-9))


def reference(dim, X, E, nbdry, M):
    """Recompute the statistics; M is nv x dim x dim, or None (identity)."""
    ref = {"dim": dim, "vertices": len(X), "elements": len(E),
           "boundary": nbdry, "has_metric": M is not None}
    vol = simplex_volumes(dim, X, E)
    ref["volume"] = math.fsum(vol)
    ref["inverted"] = int(np.sum(vol <= 0))
    # unique edges
    pairs = []
    for i in range(dim + 1):
        for j in range(i + 1, dim + 1):
            pairs.append(np.stack([E[:, i], E[:, j]], axis=1))
    P = np.concatenate(pairs)
    P.sort(axis=1)
    P = P[P[:, 0] != P[:, 1]]
    P = np.unique(P, axis=0)
    e = X[P[:, 1]] - X[P[:, 0]]
    if M is None:
        L = np.linalg.norm(e, axis=1)
    else:
        la = np.sqrt(np.einsum("ni,nij,nj->n", e, M[P[:, 0]], e))
        lb = np.sqrt(np.einsum("ni,nij,nj->n", e, M[P[:, 1]], e))
        L = log_mean(la, lb)
    ref["edges"] = len(L)
    ref["edge_min"] = float(L.min()) if len(L) else 0.0
    ref["edge_max"] = float(L.max()) if len(L) else 0.0
    ref["edge_mean"] = math.fsum(L) / len(L) if len(L) else 0.0
    h = np.bincount(hist(L, EDGE_BOUNDS), minlength=9).tolist()
    inr = int(np.sum((L >= 0.7071) & (L < 1.4142)))
    ref["edge_hist"] = h + [inr]
    ref["edge_in_range"] = inr / len(L) if len(L) else 0.0
    ref["_edge_ambiguous"] = ambiguous(L, EDGE_BOUNDS)
    # qualities
    if M is None:
        Mbar = np.broadcast_to(np.eye(dim), (len(E), dim, dim))
    else:
        Mbar = M[E].mean(axis=1)
    s = np.zeros(len(E))
    for i in range(dim + 1):
        for j in range(i + 1, dim + 1):
            d = X[E[:, j]] - X[E[:, i]]
            s += np.einsum("ni,nij,nj->n", d, Mbar, d)
    vm = vol * np.sqrt(np.linalg.det(Mbar))
    if dim == 2:
        Q = 4 * math.sqrt(3) * vm / s
    else:
        Q = 72 * math.sqrt(3) * vm / s ** 1.5
    ref["quality_worst"] = float(Q.min()) if len(Q) else 0.0
    ref["quality_best"] = float(Q.max()) if len(Q) else 0.0
    ref["quality_mean"] = math.fsum(Q) / len(Q) if len(Q) else 0.0
    qb = np.clip(np.floor(Q / 0.2), 0, 4).astype(int)
    ref["quality_hist"] = np.bincount(qb, minlength=5).tolist()
    ref["quality_above_0.5"] = float(np.sum(Q > 0.5)) / len(Q)
    ref["quality_above_0.12"] = float(np.sum(Q > 0.12)) / len(Q)
    ref["_qual_ambiguous"] = ambiguous(Q, QUAL_BOUNDS + [0.5, 0.12])
    return ref


def close(a, b, rtol=RTOL):
    if not isinstance(a, (int, float)) or isinstance(a, bool):
        return False
    return abs(a - b) <= rtol * max(abs(a), abs(b)) + 1e-14


def compare(case, got, ref):
    exact = ["dim", "vertices", "elements", "boundary", "inverted", "edges"]
    for k in exact:
        if got.get(k) != ref[k]:
            fail("%s: %s = %r, expected %r" % (case, k, got.get(k), ref[k]))
    for k in ["has_metric"]:
        if got.get(k) is not ref[k]:
            fail("%s: %s = %r, expected %r" % (case, k, got.get(k), ref[k]))
    if got.get("valid") is not True:
        fail("%s: valid = %r, expected true" % (case, got.get("valid")))
    for k in ["volume", "edge_min", "edge_max", "edge_mean", "quality_worst",
              "quality_mean", "quality_best"]:
        if not close(got.get(k), ref[k]):
            fail("%s: %s = %r, expected %r" % (case, k, got.get(k), ref[k]))
    amb_e, amb_q = ref["_edge_ambiguous"], ref["_qual_ambiguous"]
    ne, nq = max(ref["edges"], 1), max(ref["elements"], 1)
    for k, amb, n in [("edge_in_range", amb_e, ne),
                      ("quality_above_0.5", amb_q, nq),
                      ("quality_above_0.12", amb_q, nq)]:
        g = got.get(k)
        if not isinstance(g, (int, float)) or abs(g - ref[k]) > amb / n + 1e-12:
            fail("%s: %s = %r, expected %r" % (case, k, g, ref[k]))
    for k, amb in [("edge_hist", amb_e), ("quality_hist", amb_q)]:
        g = got.get(k)
        if (not isinstance(g, list) or len(g) != len(ref[k]) or
                any(abs(x - y) > amb for x, y in zip(g, ref[k]))):
            fail("%s: %s = %r, expected %r" % (case, k, g, ref[k]))


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        print("command failed (exit %d): %s\nstdout:\n%s\nstderr:\n%s" %
              (r.returncode, " ".join(cmd), r.stdout, r.stderr), file=sys.stderr)
        sys.exit(1)
    return r.stdout


def check_field(case, spec, dim, X, kind, vals):
    ekind, expected = expected_field(spec, dim, X)
    if kind != ekind:
        fail("%s: .sol type %d, expected %d" % (case, kind, ekind))
        return
    if kind == 1:
        err = np.max(np.abs(vals[:, 0] - expected[:, 0]) / expected[:, 0])
    else:
        got = full_tensors(dim, kind, vals)
        scale = np.max(np.abs(expected), axis=(1, 2))
        err = np.max(np.max(np.abs(got - expected), axis=(1, 2)) / scale)
    if not err <= RTOL:
        fail("%s: metric values differ from the documented field by %.3g "
             "(relative)" % (case, err))


def main():
    padapt = os.environ.get("PADAPT")
    if not padapt or not os.access(padapt, os.X_OK):
        print("PADAPT must name the padapt executable (got %r)" % padapt,
              file=sys.stderr)
        return 1
    # Each CLI launch costs ~0.5 s of MPI start-up: the extra cases
    # (iso-shell, no metric) run in 2D only.
    all_fields = {"box2d": ["shell", "layer", "uniform:0.2", "iso-shell:0.3",
                            None],
                  "box3d": ["shell", "layer", "uniform:0.2"]}
    for box, n in [("box2d", 6), ("box3d", 3)]:
        fields = all_fields[box]
        mesh = box + ".mesh"
        if os.path.exists(mesh):
            os.remove(mesh)
        run([padapt, "generate", box, str(n), mesh])
        dim, X, E, nbdry = read_medit(mesh)
        for field in fields:
            case = "%s %d %s" % (box, n, field or "(no metric)")
            tag = "%s_%s" % (box, (field or "none").replace(":", "_"))
            sol, js = tag + ".sol", tag + ".json"
            for p in (sol, js):
                if os.path.exists(p):
                    os.remove(p)
            cmd = [padapt, "stats", mesh]
            M = None
            if field:
                run([padapt, "metric", field, mesh, sol])
                cmd += ["-met", sol]
                kind, vals = read_sol(sol, dim)
                if len(vals) != len(X):
                    fail("%s: %d metric values for %d vertices" %
                         (case, len(vals), len(X)))
                    continue
                check_field(case, field, dim, X, kind, vals)
                M = full_tensors(dim, kind, vals)
            run(cmd + ["-json", js])
            with open(js) as f:
                got = json.load(f)
            before = len(failures)
            compare(case, got, reference(dim, X, E, nbdry, M))
            print("%-28s %s" % (case, "ok" if len(failures) == before
                                else "FAILED"))
    if failures:
        print("%d mismatch(es) between padapt stats and the independent "
              "computation" % len(failures), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
