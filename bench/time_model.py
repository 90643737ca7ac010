#!/usr/bin/python3
"""time_model.py -- a model of the parallel adaptation's time at larger
process counts, from the measured per-step figures of one run.

    /usr/bin/python3 bench/time_model.py REPORT.json [--out N] [--procs P...]
                     [--bandwidth GBs] [--latency us]

REPORT.json is the -json report of `mpiexec -n p padapt adapt` (for instance
one rung of bench/scale.sh). For each iteration the report gives the wall
time of each step (max over the ranks), the remeshing busy time summed over
the ranks, the bytes moved between ranks and the elements.

The model, per iteration i of the measured run at p ranks:
  remesh(P)  = busy_i / min(P, k_i(P)) * balance_i
               k_i(P) = the pieces at P ranks: the measured pieces_i * P / p,
               at most tagged_i * N / N_measured / 2000 (the smallest work
               worth a piece, min_piece_work); balance_i = wall /
               (busy_i / min(p, pieces_i)), the measured max/mean busy time
               of the ranks that had a piece
  local(P)   = (tag + pieces + gather + reintegrate)_i * p / P
                                             (work per element, shared out)
  comm(P)    = bytes_i * p / P / bandwidth   (each rank's share of the bytes,
                                              sent at the given bandwidth)
               + log2(P) * latency * 30      (about 30 collectives per
                                              iteration, each log2 P steps)
Everything scales with the output size N / N_measured (the remeshing work is
about linear in the output elements), so the model answers: how long would
this adaptation take, scaled to N output elements, on P processes?

It is a model, not a measurement: it assumes the same pieces per rank, the
same balance and iterations, and a network with the given bandwidth and
latency. Its purpose is to place the measured per-process costs next to the
seed paper's run: 27 M -> 609 M tetrahedra on 240 processes in 35 minutes
(Lachat, Dobrzynski, Pellegrini, PaMPA + MMG3D).
"""
import argparse
import json
import math


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("report")
    ap.add_argument("--out", type=float, default=609e6,
                    help="output elements to scale to (default: the paper's 609 M)")
    ap.add_argument("--procs", type=int, nargs="*", default=[2, 8, 16, 64, 240])
    ap.add_argument("--bandwidth", type=float, default=5.0,
                    help="GB/s per process (default 5)")
    ap.add_argument("--latency", type=float, default=5.0,
                    help="microseconds per message step (default 5)")
    a = ap.parse_args()
    r = json.load(open(a.report))
    p = r["processes"]
    n = r["elements"]
    scale = a.out / n
    its = r["iteration_detail"]
    print(f"# measured: {n:,} elements on {p} processes in {r['time_s']:.1f} s "
          f"({len(its)} iterations); scaled to {a.out:,.0f} elements (x{scale:.1f})")
    for it in its:
        busy = it["remesh_busy_s"]
        bal = it["remesh_s"] / (busy / min(p, it["pieces"])) if busy > 0 else 1.0
        other = sum(it[k] for k in ("tag_s", "pieces_s", "gather_s", "reintegrate_s"))
        print(f"#   iter {it['iter']}: {it['pieces']} pieces, remesh busy {busy:.2f} s "
              f"(balance max/mean "
              f"{bal:.2f}), other steps {other:.2f} s, {it['bytes_moved'] / 1e6:.1f} MB moved")
    print(f"# network model: {a.bandwidth} GB/s per process, {a.latency} us per step")
    print(f"{'P':>5} {'remesh s':>10} {'local s':>9} {'comm s':>8} {'total s':>9} "
          f"{'total min':>9} {'elements/s/process':>19}")
    for P in a.procs:
        tr = tl = tc = 0.0
        for it in its:
            busy = it["remesh_busy_s"] * scale
            busy_ranks = min(p, it["pieces"])
            bal = (it["remesh_s"] / (it["remesh_busy_s"] / busy_ranks)
                   if it["remesh_busy_s"] > 0 else 1.0)
            pieces = min(it["pieces"] * P / p, max(1.0, it["tagged"] * scale / 2000))
            tr += busy / min(P, pieces) * bal
            other = sum(it[k] for k in ("tag_s", "pieces_s", "gather_s", "reintegrate_s"))
            tl += other * scale * p / P
            tc += it["bytes_moved"] * scale / P / (a.bandwidth * 1e9)
            tc += math.log2(max(P, 2)) * a.latency * 1e-6 * 30
        tot = tr + tl + tc
        print(f"{P:>5} {tr:>10.1f} {tl:>9.1f} {tc:>8.2f} {tot:>9.1f} {tot / 60:>9.1f} "
              f"{a.out / tot / P:>19,.0f}")
    print("# the seed paper: 609 M tetrahedra on 240 processes in 35 min "
          f"= {609e6 / (35 * 60) / 240:,.0f} elements/s/process")


if __name__ == "__main__":
    main()
