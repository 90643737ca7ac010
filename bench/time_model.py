#!/usr/bin/python3
"""time_model.py -- a scaling model of the parallel adaptation, fitted on
measured runs and checked against the runs it was not fitted on.

    /usr/bin/python3 bench/time_model.py DIR [--n N] [--procs P ...]
                     [--per-rank N] [--bandwidth GBs] [--latency us]

DIR holds the -json reports that bench/efficiency.sh writes:
  weak-np{1,2,4,8}.json  (optional) the rod refined to np x 2 M tets;
  work-np1.json, work-np{2,4,8}.json  one job (the rod to 0.8 M tets) at
      np 1, 2, 4 and 8 -- the remeshing work, "remesh_cpu_s", is CPU time
      summed over the ranks; work-copyP-{alone,1..P}.json (optional): the
      sequential job of a rank's size alone and P copies at once, whose
      ratio is what sharing the cores adds to the CPU time (printed);
  time-rod-np1.json, time-rod-np2.json  the same job at np 1 and 2 on a
      quiet machine (wall clock of each step).

The model, for N output elements on P processes (one per core):

  work      W(P, N) = w N (1 + a (P^(1/3) - 1) (N0 / N)^(1/3))
            w = the sequential remeshing work per output element (np=1);
            the second term is the work redone around the pieces' frozen
            skins: P pieces of N / P elements have P^(1/3) N^(2/3) skin
            elements in all, none for one piece; a is fitted on np=2 only,
            and the model's W at np 4 and 8 is printed beside the measured.
  remesh    T_r = w N / P x b + (W(P, N) - w N) / min(P, k)
            the first iteration's pieces carry the sequential work shared
            out, with the measured balance b (the slowest piece over the
            mean, np=2); the redone work runs in the later iterations' k
            pieces, k = its work in output elements over min_piece_work
            (2 000), at most P.
  steps     T_s = s N / P: tag, pieces, gather and reintegration, measured
            per element per rank at np=2 (all are loops over the local
            mesh, records, or a whole-mesh rebuild).
  comm      bytes moved per element (np=2, scaled like the skin for the
            later iterations) x N / P at the given bandwidth per process,
            plus 30 collectives per iteration of log2 P steps each.
  io        the measured np=1 time outside the remesher per element,
            divided by P (distributed input and output).

Validation printed: W at np 4 and 8 (fitted on np=2 only) and T at np=2
(built from the np=1 run and the work fit) against the measured; the
assumptions are those above: the same iterations and balance at every P,
pieces as cubes, a network of the given bandwidth and latency.
"""
import argparse
import json
import math
import os

MIN_PIECE_WORK = 2000  # pa_adapt_opts.min_piece_work's default


def load(d, name):
    p = os.path.join(d, name)
    return json.load(open(p)) if os.path.exists(p) else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--n", type=float, default=101247746,
                    help="output elements for the strong-scaling table (the 100 M rod)")
    ap.add_argument("--per-rank", type=float, default=2e6,
                    help="output elements per process for the weak-scaling table")
    ap.add_argument("--procs", type=int, nargs="*", default=[16, 32, 64, 128, 256])
    ap.add_argument("--bandwidth", type=float, default=5.0, help="GB/s per process")
    ap.add_argument("--latency", type=float, default=5.0, help="microseconds per step")
    a = ap.parse_args()

    seq = load(a.dir, "work-np1.json")
    par = {p: load(a.dir, "work-np%d.json" % p) for p in (2, 4, 8)}
    if not seq or not par[2]:
        raise SystemExit("time_model: %s needs work-np1.json and work-np2.json "
                         "(bench/efficiency.sh work)" % a.dir)
    n0 = seq["elements"]
    w = seq["remesh_cpu_s"] / n0

    def extra(p):  # redone work over sequential work, skin term of P pieces
        return (p ** (1 / 3) - 1)

    # redone work cannot be negative: a ratio below 1 at np=2 is noise in
    # the CPU times, and a = 0 (no work redone) is what it measures
    alpha = max(0.0, (par[2]["remesh_cpu_s"] / seq["remesh_cpu_s"] - 1) / extra(2))

    def over_copies(p, ratio):  # the ratio over what sharing the cores adds
        alone = load(a.dir, "work-copy%d-alone.json" % p)
        copies = [load(a.dir, "work-copy%d-%d.json" % (p, i)) for i in range(1, p + 1)]
        if not alone or not all(copies):
            return ""
        cf = sum(c["remesh_cpu_s"] for c in copies) / p / alone["remesh_cpu_s"]
        return "; %d copies at once: %.3f, %.3f x over that" % (p, cf, ratio / cf)

    def work(p, n):
        return w * n * (1 + alpha * extra(p) * (n0 / n) ** (1 / 3))

    print("# work: %d elements, sequential remeshing %.3f us per element; "
          "fitted on np=2: a = %.4f" % (n0, 1e6 * w, alpha))
    for p in (2, 4, 8):
        r = par[p]
        if r:
            print("#   np=%d: measured %.2f s (%.3f x np=1, %d iterations%s), model %.2f s (%.3f x)"
                  % (p, r["remesh_cpu_s"], r["remesh_cpu_s"] / seq["remesh_cpu_s"],
                     r["iterations"], over_copies(p, r["remesh_cpu_s"] / seq["remesh_cpu_s"]),
                     work(p, n0), work(p, n0) / seq["remesh_cpu_s"]))

    weak = {p: load(a.dir, "weak-np%d.json" % p) for p in (1, 2, 4, 8)}
    if weak[1]:
        u1 = weak[1]["remesh_cpu_s"] / weak[1]["elements"]
        for p in (1, 2, 4, 8):
            r = weak[p]
            if r:
                n = r["elements"]
                print("#   weak np=%d: %d elements, measured %.3f us per element"
                      " (%.3f x np=1), model %.3f us (%.3f x)"
                      % (p, n, 1e6 * r["remesh_cpu_s"] / n, r["remesh_cpu_s"] / n / u1,
                         1e6 * work(p, n) / n, work(p, n) / n / (w * (1 + alpha * extra(1)))))

    t1, t2 = load(a.dir, "time-rod-np1.json"), load(a.dir, "time-rod-np2.json")
    r2 = t2 or par[2]
    it1 = r2["iteration_detail"][0]
    # balance of the first iteration: its wall time over the mean busy time
    bal = it1["remesh_s"] / (it1["remesh_busy_s"] / min(2, it1["pieces"]))
    steps = sum(r2["steps_s"][k] for k in ("tag", "pieces", "gather", "reintegrate"))
    s = steps * 2 / r2["elements"]  # seconds per element per rank
    later = r2["iteration_detail"][1:]
    bpe1 = it1["bytes_moved"] / r2["elements"]
    bpe2 = sum(i["bytes_moved"] for i in later) / r2["elements"]
    io = 0.0
    if t1:
        io = max(0.0, t1["time_s"] - t1["remesh_cpu_s"]) / n0
    print("# np=2 figures%s: first-iteration balance %.3f, steps %.3f us per element"
          " per rank, %.1f + %.1f bytes moved per element; io %.3f us per element"
          % ("" if t2 else " (from the work run: not quiet)", bal, 1e6 * s, bpe1, bpe2,
             1e6 * io))

    def skin(p, n):  # the skin elements of P pieces of N, over np=2's at n0
        return extra(p) / extra(2) * (n / n0) ** (2 / 3)

    def model(p, n):
        redone = work(p, n) - w * n
        k = min(p, max(1.0, redone / w / MIN_PIECE_WORK))
        tr = w * n / p * bal + redone / k
        ts = s * n / p
        tc = (bpe1 * n + bpe2 * n0 * skin(p, n)) / p / (a.bandwidth * 1e9) \
            + (1 + len(later)) * 30 * math.log2(max(p, 2)) * a.latency * 1e-6
        tio = io * n / p
        return tr, ts, tc, tio

    def own(r):  # the adaptation's time, without measuring the result
        return r["time_s"] - r.get("steps_s", {}).get("measure", 0.0)

    if t1 and t2:
        tr, ts, tc, tio = model(2, n0)
        pred = tr + ts + tc + tio
        print("#   np=2 time: measured %.2f s (np=1 %.2f s, efficiency %.3f), model %.2f s"
              " (efficiency %.3f)" % (own(t2), own(t1),
                                      own(t1) / (2 * own(t2)), pred,
                                      own(t1) / (2 * pred)))
    print("# network: %.1f GB/s per process, %.1f us per step" % (a.bandwidth, a.latency))
    for title, sizes in (("strong: %.0f elements" % a.n, [(p, a.n) for p in a.procs]),
                         ("weak: %.0f elements per process" % a.per_rank,
                          [(p, a.per_rank * p) for p in a.procs])):
        print("# " + title)
        print("%5s %14s %9s %9s %8s %8s %9s %10s %12s" % (
            "P", "elements", "work x", "remesh s", "steps s", "comm s", "io s", "total s",
            "efficiency"))
        for p, n in sizes:
            tr, ts, tc, tio = model(p, n)
            tot = tr + ts + tc + tio
            ideal = w * n / p + io * n / p
            print("%5d %14.0f %9.3f %9.1f %8.1f %8.2f %9.1f %10.1f %12.3f" % (
                p, n, work(p, n) / (w * n), tr, ts, tc, tio, tot, ideal / tot))


if __name__ == "__main__":
    main()
