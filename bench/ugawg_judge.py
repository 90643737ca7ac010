#!/usr/bin/python3
"""ugawg_judge.py -- the independent judge of bench/ugawg.sh.

Re-derives, from the UGAWG analytic fields alone (never from padapt's
metric or statistics code), what the benchmark reports about a final mesh:

  * the share of edges whose metric length lies in [0.7071, 1.4142), the
    length being L = (la - lb) / ln(la / lb), la = sqrt(e^T M(a) e) (the
    arithmetic mean (la + lb) / 2 when |la - lb| < 1e-3 max(la, lb));
  * the complexity C = integral of sqrt(det M) over the unit square/cube,
    by composite 5-point Gauss-Legendre quadrature of an exact 1D reduction
    (the fields depend on one coordinate, z or y, or on r = |(x, y)|; for
    the polar fields the square's share of each circle, r theta(r), is
    exact), with break points at every kink, 20000 panels per piece; and,
    as a cross-check, the per-element sum vol * sqrt(det M(centroid)) over
    the final mesh;
  * the largest relative difference between the metric file the run wrote
    (`padapt metric`) and the analytic tensors, so a wrong field is seen.

Subcommands (used by ugawg.sh; run with /usr/bin/python3, numpy and meshio):
  header                          print the table header
  record KEY=VALUE ...            judge one run, print its table row and
                                  append a JSON record to records=PATH
  summary RECORDS.jsonl           padapt against Mmg per case; pass history
  complexity FIELD DIM            print C
"""
import json
import math
import os
import sys
import warnings

import numpy as np

# The fields (Ibanez et al., "A benchmark case for unstructured mesh
# adaptation"); h0 = H / 100.
H = 0.1
H0 = 0.001
# Edge-length band, the literal values Mmg and padapt print.
IN_LO, IN_HI = 0.7071, 1.4142
# Below this relative gap between la and lb the log mean is ill-conditioned.
LOGMEAN_EPS = 1e-3
GL_PANELS = 20000


def ramp(s):
    return H0 + 2.0 * (H - H0) * np.abs(s - 0.5)


def polar_sizes(field, r):
    hr = ramp(r)
    if field == "polar1":
        ht = np.full_like(r, H)
    else:
        d0 = np.minimum(10.0 * np.abs(r - 0.5), 1.0)
        ht = H * d0 + (H / 4.0) * (1.0 - d0)
    return hr, ht


def metric_at(field, dim, x):
    """Full tensors (n, dim, dim) of the analytic field at points x (n, dim)."""
    n = x.shape[0]
    m = np.zeros((n, dim, dim))
    if field == "linear":
        for i in range(dim - 1):
            m[:, i, i] = 1.0 / H**2
        m[:, dim - 1, dim - 1] = 1.0 / ramp(x[:, dim - 1]) ** 2
        return m
    r = np.hypot(x[:, 0], x[:, 1])
    t = np.arctan2(x[:, 1], x[:, 0])
    hr, ht = polar_sizes(field, r)
    c, s = np.cos(t), np.sin(t)
    lr, lt = 1.0 / hr**2, 1.0 / ht**2
    m[:, 0, 0] = lr * c * c + lt * s * s
    m[:, 0, 1] = m[:, 1, 0] = (lr - lt) * c * s
    m[:, 1, 1] = lr * s * s + lt * c * c
    if dim == 3:
        m[:, 2, 2] = 1.0 / H**2
    return m


def sqrt_det(field, dim, x):
    """sqrt(det M) from the sizes (no tensor): 1 / prod(h)."""
    if field == "linear":
        return 1.0 / (H ** (dim - 1) * ramp(x[:, dim - 1]))
    r = np.hypot(x[:, 0], x[:, 1])
    hr, ht = polar_sizes(field, r)
    return 1.0 / (hr * ht * (H if dim == 3 else 1.0))


def gauss_1d(f, breaks):
    """Composite 5-point Gauss-Legendre of f over [breaks[0], breaks[-1]]."""
    xg, wg = np.polynomial.legendre.leggauss(5)
    total = 0.0
    for a, b in zip(breaks[:-1], breaks[1:]):
        edges = np.linspace(a, b, GL_PANELS + 1)
        mid = 0.5 * (edges[:-1] + edges[1:])
        half = 0.5 * (edges[1:] - edges[:-1])
        pts = (mid[:, None] + half[:, None] * xg[None, :]).ravel()
        wts = (half[:, None] * wg[None, :]).ravel()
        total += float(np.sum(f(pts) * wts))
    return total


def complexity(field, dim):
    if field == "linear":
        # sqrt(det M) = H^-(dim-1) / ramp(s), s the last coordinate.
        return gauss_1d(lambda s: 1.0 / ramp(s), [0.0, 0.5, 1.0]) / H ** (dim - 1)

    # Polar: f(r) times the arc of radius r inside the unit square.
    def integrand(r):
        hr, ht = polar_sizes(field, r)
        arc = np.where(r <= 1.0, 0.5 * math.pi,
                       0.5 * math.pi - 2.0 * np.arccos(np.minimum(1.0, 1.0 / np.maximum(r, 1e-300))))
        return r * arc / (hr * ht)

    c2 = gauss_1d(integrand, [0.0, 0.4, 0.5, 0.6, 1.0, math.sqrt(2.0)])
    return c2 / H if dim == 3 else c2


def meshio_read(path):
    """meshio.read without its notes on stderr ("doesn't know keyword" for
    Mmg's Ridges etc.)."""
    import meshio

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        saved = os.dup(2)
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            try:
                return meshio.read(path)
            finally:
                os.dup2(saved, 2)
                os.close(saved)


def read_mesh(path, dim):
    mesh = meshio_read(path)
    x = np.asarray(mesh.points, dtype=float)[:, :dim]
    kind = "tetra" if dim == 3 else "triangle"
    cells = np.concatenate([c.data for c in mesh.cells if c.type == kind])
    return x, cells.astype(np.int64)


def edge_in_range(field, dim, x, cells):
    k = dim + 1
    pairs = np.array([(i, j) for i in range(k) for j in range(i + 1, k)])
    e = np.sort(cells[:, pairs].reshape(-1, 2), axis=1)
    e = np.unique(e, axis=0)
    m = metric_at(field, dim, x)
    d = x[e[:, 1]] - x[e[:, 0]]
    la = np.sqrt(np.einsum("ni,nij,nj->n", d, m[e[:, 0]], d))
    lb = np.sqrt(np.einsum("ni,nij,nj->n", d, m[e[:, 1]], d))
    close = np.abs(la - lb) < LOGMEAN_EPS * np.maximum(la, lb)
    with np.errstate(divide="ignore", invalid="ignore"):
        length = np.where(close, 0.5 * (la + lb), (la - lb) / np.log(la / lb))
    inr = (length >= IN_LO) & (length < IN_HI)
    return float(np.mean(inr)), len(e)


def element_complexity(field, dim, x, cells):
    v = x[cells]
    a = v[:, 1:, :] - v[:, :1, :]
    vol = np.abs(np.linalg.det(a)) / math.factorial(dim)
    return float(np.sum(vol * sqrt_det(field, dim, v.mean(axis=1))))


def read_sol(path, dim):
    """Tensors (n, ncomp) of an ASCII Medit .sol with one field."""
    tok = open(path).read().split()
    i = tok.index("SolAtVertices")
    n, ntyp, typ = int(tok[i + 1]), int(tok[i + 2]), int(tok[i + 3])
    ncomp = {1: 1, 2: dim, 3: dim * (dim + 1) // 2}[typ]
    if ntyp != 1:
        raise ValueError("one field expected")
    vals = np.array(tok[i + 4:i + 4 + n * ncomp], dtype=float)
    return vals.reshape(n, ncomp)


def sol_error(field, dim, x, path):
    """Largest |sol - analytic| / max|analytic| over the vertices."""
    try:
        sol = read_sol(path, dim)
    except (OSError, ValueError, IndexError) as err:
        return f"unreadable ({err})"
    if sol.shape != (x.shape[0], dim * (dim + 1) // 2):
        return f"shape {sol.shape}"
    m = metric_at(field, dim, x)
    # Medit order: m11 m12 m22 [m13 m23 m33].
    idx = [(0, 0), (0, 1), (1, 1)] + ([(0, 2), (1, 2), (2, 2)] if dim == 3 else [])
    ref = np.stack([m[:, i, j] for i, j in idx], axis=1)
    scale = np.max(np.abs(ref), axis=1)
    return float(np.max(np.max(np.abs(sol - ref), axis=1) / scale))


COLS = ("tool", "case", "dim", "start", "np", "elements", "el/C",
        "in-range pa", "in-range py", "Q worst", "Q mean", "adapt s",
        "el/s", "wall s")
FMT = "{:<6} {:<6} {:>3} {:<5} {:>2} {:>9} {:>6} {:>11} {:>11} {:>7} {:>6} {:>8} {:>8} {:>7}"


def header():
    print(FMT.format(*COLS))
    print(FMT.format(*("-" * len(c) for c in COLS)))


def fnum(v, spec):
    return "-" if v is None else format(v, spec)


def record(args):
    a = dict(kv.split("=", 1) for kv in args)
    field, dim = a["field"], int(a["dim"])
    rec = {k: a[k] for k in ("tool", "case", "start", "np")}
    rec["dim"] = dim
    passes = []
    if os.path.exists(a["passes"]):
        for line in open(a["passes"]):
            p = line.split()
            passes.append({"elements": int(p[1]), "adapt_s": float(p[2]),
                           "wall_s": float(p[3]), "adapt_from": p[4],
                           "outcome": p[5] if len(p) > 5 else "-"})
    rec["passes"] = passes
    rec["failed"] = a.get("failed", "")
    rec["complexity"] = complexity(field, dim)
    stats = {}
    if not rec["failed"] and os.path.exists(a["stats"]):
        stats = json.load(open(a["stats"]))
    if not rec["failed"]:
        x, cells = read_mesh(a["mesh"], dim)
        rec["inrange_py"], rec["edges_py"] = edge_in_range(field, dim, x, cells)
        rec["complexity_elem"] = element_complexity(field, dim, x, cells)
        rec["sol_error"] = sol_error(field, dim, x, a["sol"])
        rec["elements"] = int(cells.shape[0])
    rec["inrange_pa"] = stats.get("edge_in_range")
    rec["edges_pa"] = stats.get("edges")
    rec["quality_worst"] = stats.get("quality_worst")
    rec["quality_mean"] = stats.get("quality_mean")
    rec["valid"] = stats.get("valid")
    rec["adapt_s"] = sum(p["adapt_s"] for p in passes)
    rec["wall_s"] = sum(p["wall_s"] for p in passes)
    with open(a["records"], "a") as f:
        f.write(json.dumps(rec) + "\n")
    lead = (rec["tool"], rec["case"], dim, rec["start"], rec["np"])
    if rec["failed"]:
        print(FMT.format(*lead, *(["-"] * 9)) + f"  FAILED: {rec['failed']}")
        return
    el = rec["elements"]
    t = rec["adapt_s"]
    mark = "" if all(p["adapt_from"] != "wall" for p in passes) else "*"
    row = FMT.format(*lead, el, fnum(el / rec["complexity"], ".3f"),
                     fnum(None if rec["inrange_pa"] is None else 100 * rec["inrange_pa"], ".2f"),
                     fnum(100 * rec["inrange_py"], ".2f"),
                     fnum(rec["quality_worst"], ".4f"), fnum(rec["quality_mean"], ".3f"),
                     fnum(t, ".2f") + mark, fnum(el / t if t > 0 else None, ".0f"),
                     fnum(rec["wall_s"], ".2f"))
    notes = []
    odd = [f"pass {i + 1}: {p['outcome']}" for i, p in enumerate(passes)
           if p["outcome"] not in ("success", "-")]
    if odd:
        notes.append("adapt outcome " + ", ".join(odd))
    if rec["valid"] is False:
        notes.append("INVALID mesh (padapt stats)")
    if rec["edges_pa"] is not None and rec["edges_pa"] != rec["edges_py"]:
        notes.append(f"edge counts differ: padapt {rec['edges_pa']}, python {rec['edges_py']}")
    if rec["inrange_pa"] is not None and abs(rec["inrange_pa"] - rec["inrange_py"]) > 1e-4:
        notes.append("padapt stats and the judge disagree on the in-range share")
    if isinstance(rec["sol_error"], str) or rec["sol_error"] > 1e-9:
        notes.append(f"metric file differs from the analytic field: {rec['sol_error']}")
    print(row + ("  " + "; ".join(notes) if notes else ""), flush=True)


def summary(path):
    recs = [json.loads(line) for line in open(path)]
    if not recs:
        return
    print("\n## complexity C (1D Gauss-Legendre of the exact reduction) and the "
          "per-element check on each final mesh (centroid rule)")
    seen = set()
    for r in recs:
        key = (r["case"], r["dim"])
        if key not in seen:
            seen.add(key)
            print(f"  {r['case']:<6} {r['dim']}D  C = {r['complexity']:.1f}")
    for r in recs:
        if "complexity_elem" in r:
            print(f"    {r['tool']:<6} {r['case']:<6} {r['dim']}D {r['start']:<5} np {r['np']}: "
                  f"centroid rule on the final mesh {r['complexity_elem']:.1f} "
                  f"({100 * (r['complexity_elem'] / r['complexity'] - 1):+.2f} %)")
    mmg = {(r["case"], r["dim"], r["start"]): r for r in recs
           if r["tool"] == "mmg" and not r["failed"]}
    pa = [r for r in recs if r["tool"] == "padapt" and not r["failed"]]
    if mmg and pa:
        print("\n## padapt against Mmg (same case, same start; Mmg's adapt time is "
              "the library time it prints, wall its command time)")
        print("  case   dim start np  elements pa/mmg  el/s pa/mmg (adapt)  el/s pa/mmg (wall)")
        for r in pa:
            m = mmg.get((r["case"], r["dim"], r["start"]))
            if not m:
                continue
            ra = (r["elements"] / r["adapt_s"]) / (m["elements"] / m["adapt_s"]) \
                if r["adapt_s"] > 0 and m["adapt_s"] > 0 else None
            rw = (r["elements"] / r["wall_s"]) / (m["elements"] / m["wall_s"]) \
                if r["wall_s"] > 0 and m["wall_s"] > 0 else None
            print(f"  {r['case']:<6} {r['dim']:>3} {r['start']:<5} {r['np']:>2}  "
                  f"{r['elements'] / m['elements']:>15.3f}  {fnum(ra, '>18.2f')}  "
                  f"{fnum(rw, '>17.2f')}")
    print("\n## pass history: elements (adapt s) after each pass")
    for r in recs:
        hist = " -> ".join(f"{p['elements']} ({p['adapt_s']:.3f})" for p in r["passes"])
        tail = f"  FAILED: {r['failed']}" if r["failed"] else ""
        print(f"  {r['tool']:<6} {r['case']:<6} {r['dim']}D {r['start']:<5} np {r['np']}: "
              f"{hist}{tail}")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    cmd = sys.argv[1]
    if cmd == "header":
        header()
    elif cmd == "record":
        record(sys.argv[2:])
    elif cmd == "summary":
        summary(sys.argv[2])
    elif cmd == "complexity":
        print(f"{complexity(sys.argv[2], int(sys.argv[3])):.6f}")
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
