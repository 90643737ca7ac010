#!/usr/bin/python3
"""ugawg_bound.py -- how close to the ideal count a mesh of unit edges can
come on the UGAWG fields in 2D.

The ideal count C / (sqrt(3)/4) (C = integral of sqrt(det M), bench/
ugawg_judge.py) is the number of equilateral triangles of unit edges that
tile the square, which needs a metric constant at the scale of an element.
The polar fields stretch elements along circles: a straight edge along a
circle is a chord, which leaves the circle's direction by half its angle at
each end, where the radial size is up to 100 times smaller than the
tangential one. A chord of unit length (measured as the judge measures,
from its end tensors) is then shorter than the tangential size h_t, and a
layer of elements between two circles holds h_t / L_max(r) times as many
as the ideal count gives it.

For each field this prints the count of a mesh whose tangential edges are
unit chords, over the ideal count: the integral over r of the complexity
density times h_t / L_max(r), over C; then the same with chords as long
as the judge's range allows (sqrt(2)), the radial edges still unit: no
mesh with its edges in range and unit across the circles holds fewer.
Linear's anisotropy does not turn, so its ratios are 1 and 1/sqrt(2) (a
check of the computation).

    /usr/bin/python3 bench/ugawg_bound.py
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ugawg_judge import H, metric_at, polar_sizes, ramp  # noqa: E402


def judge_length(field, a, b):
    """The judge's metric length of the segment ab (2D points)."""
    x = np.array([a, b])
    m = metric_at(field, 2, x)
    d = x[1] - x[0]
    la, lb = math.sqrt(d @ m[0] @ d), math.sqrt(d @ m[1] @ d)
    if abs(la - lb) < 1e-3 * max(la, lb):
        return 0.5 * (la + lb)
    return (la - lb) / math.log(la / lb)


def chord(field, r, length):
    """The metric length of the chord of Euclidean length `length` of the
    circle of radius r (centred at the square's diagonal: the fields turn
    with the angle, so any position gives the same)."""
    phi = math.asin(min(length / (2 * r), 1.0))
    t0 = math.pi / 4
    a = (r * math.cos(t0 - phi), r * math.sin(t0 - phi))
    b = (r * math.cos(t0 + phi), r * math.sin(t0 + phi))
    return judge_length(field, a, b)


def longest_chord(field, r, ht, length):
    """The longest chord of metric length at most `length` (bisection on
    its Euclidean length, which the metric length grows with)."""
    lo, hi = 0.0, min(3 * length * ht, 2 * r)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if chord(field, r, mid) > length:
            hi = mid
        else:
            lo = mid
    return lo


def ratio(field, length=1.0, n=2000):
    """The count of chords of metric length `length` over the ideal count
    (midpoint rule in r)."""
    if field == "linear":
        return 1.0 / length
    rs = (np.arange(n) + 0.5) * math.sqrt(2) / n
    num = den = 0.0
    for r in rs:
        arc = r * (0.5 * math.pi if r <= 1 else
                   0.5 * math.pi - 2 * math.acos(1 / r))
        hr, ht = polar_sizes(field, np.array([r]))
        w = arc / (hr[0] * ht[0])
        lmax = longest_chord(field, r, ht[0], length)
        num += w * ht[0] / lmax
        den += w
    return num / den


def main():
    assert abs(ramp(0.5) - H / 100) < 1e-15
    for field in ("linear", "polar1", "polar2"):
        print("2D %-7s a mesh of unit chords holds %.3f x the ideal count, "
              "of chords of sqrt(2) %.3f x"
              % (field, ratio(field), ratio(field, math.sqrt(2))))


if __name__ == "__main__":
    main()
