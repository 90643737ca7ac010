#!/usr/bin/env python3
"""plot.py CASE.json OUT.svg -- error against vertices, adapted and uniform,
on log-log axes, from the JSON run.sh writes (Python's standard library only).
"""
import json
import math
import sys

W, H = 640, 440
LEFT, RIGHT, TOP, BOTTOM = 80, 20, 40, 60
SERIES = (("uniform", "#888888", "uniform meshes"),
          ("adapted", "#c0392b", "adapted (padapt)"))


def decades(lo, hi):
    """Log10 range [a, b] of whole decades around [lo, hi]."""
    return math.floor(math.log10(lo)), math.ceil(math.log10(hi))


def main(src, dst):
    with open(src) as f:
        data = json.load(f)
    pts = [(p["vertices"], p["error"]) for k, _, _ in SERIES for p in data[k]]
    xa, xb = decades(min(p[0] for p in pts), max(p[0] for p in pts))
    ya, yb = decades(min(p[1] for p in pts), max(p[1] for p in pts))

    def sx(v):
        return LEFT + (math.log10(v) - xa) / (xb - xa) * (W - LEFT - RIGHT)

    def sy(e):
        return H - BOTTOM - (math.log10(e) - ya) / (yb - ya) * (H - TOP - BOTTOM)

    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" '
           'font-family="sans-serif" font-size="12">' % (W, H),
           '<rect width="100%" height="100%" fill="white"/>',
           '<text x="%d" y="22" font-size="15">%s: error against vertices</text>'
           % (LEFT, data["case"])]
    for d in range(xa, xb + 1):
        x = sx(10 ** d)
        out.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>'
                   % (x, TOP, x, H - BOTTOM))
        out.append('<text x="%.1f" y="%d" text-anchor="middle">1e%d</text>'
                   % (x, H - BOTTOM + 18, d))
    for d in range(ya, yb + 1):
        y = sy(10 ** d)
        out.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>'
                   % (LEFT, y, W - RIGHT, y))
        out.append('<text x="%d" y="%.1f" text-anchor="end">1e%d</text>'
                   % (LEFT - 6, y + 4, d))
    out.append('<rect x="%d" y="%d" width="%d" height="%d" fill="none" '
               'stroke="black"/>' % (LEFT, TOP, W - LEFT - RIGHT, H - TOP - BOTTOM))
    out.append('<text x="%d" y="%d" text-anchor="middle">vertices</text>'
               % ((LEFT + W - RIGHT) // 2, H - 15))
    out.append('<text transform="translate(18,%d) rotate(-90)" '
               'text-anchor="middle">L2 error</text>' % ((TOP + H - BOTTOM) // 2))
    for i, (key, color, label) in enumerate(SERIES):
        xy = sorted((sx(p["vertices"]), sy(p["error"])) for p in data[key])
        if xy:
            out.append('<polyline fill="none" stroke="%s" stroke-width="2" '
                       'points="%s"/>' % (color, " ".join("%.1f,%.1f" % p for p in xy)))
        for x, y in xy:
            out.append('<circle cx="%.1f" cy="%.1f" r="4" fill="%s"/>' % (x, y, color))
        ly = TOP + 20 + 18 * i
        out.append('<circle cx="%d" cy="%d" r="4" fill="%s"/>' % (W - RIGHT - 150, ly - 4, color))
        out.append('<text x="%d" y="%d">%s</text>' % (W - RIGHT - 140, ly, label))
    out.append("</svg>")
    with open(dst, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: plot.py CASE.json OUT.svg")
    main(sys.argv[1], sys.argv[2])
