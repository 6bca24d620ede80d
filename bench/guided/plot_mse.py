#!/usr/bin/env python3
"""bench/guided/plot_mse.py OUT_DIR SVG [SCENE...] — MSE vs spp (log-log, median
over seeds) of equal_time.sh's single-scattering runs (environment vs
two_step) and max_depth-8 runs (pathtrace vs guided), one panel per scene,
as a self-contained SVG (no plotting library needed). The paper's Figs.
11-13 in form; x is samples per pixel, and a second panel row uses render
CPU ms (the equal-time view).
"""
import json
import math
import statistics
import sys
from collections import defaultdict

COLORS = {"environment": "#d4a017", "two_step": "#c2185b", "pathtrace": "#1f77b4",
          "guided_depth0": "#2ca02c", "guided_depth1": "#9467bd"}


def series(out, scenes):
    data = defaultdict(lambda: defaultdict(list))  # (scene, kind, method) -> spp -> [(mse, cpu)]
    for name in ("single", "multiple"):
        try:
            lines = open(f"{out}/{name}.jsonl").read().splitlines()
        except OSError:
            continue
        for line in lines:
            o = json.loads(line)
            if o["metric"] != "convergence.mse":
                continue
            sc, kind, method = o["label"].split()[:3]
            if scenes and sc not in scenes:
                continue
            data[(sc, kind, method)][o["spp"]].append((o["value"], o["cpu_ms"]))
    return data


def main():
    out, svg = sys.argv[1], sys.argv[2]
    scenes = sys.argv[3:]
    data = series(out, scenes)
    panels = sorted({(k[0], k[1]) for k in data}, key=lambda p: (scenes.index(p[0]) if p[0] in scenes else 99, p[0], p[1] != "single"))
    W, H, pad = 300, 220, 48
    cols = min(4, len(panels))
    blocks = (len(panels) + cols - 1) // cols
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W * cols}" height="{2 * H * blocks}" '
             f'font-family="sans-serif" font-size="10">', f'<rect width="100%" height="100%" fill="white"/>']
    for pi, (sc, kind) in enumerate(panels):
        ci, block = pi % cols, pi // cols
        methods = sorted(m for (s, k, m) in data if s == sc and k == kind)
        for ri, xkey in enumerate(("spp", "cpu")):
            x0, y0 = ci * W + pad, (2 * block + ri) * H + 20
            pw, ph = W - pad - 10, H - 60
            pts = {}
            for m in methods:
                pts[m] = [((spp if xkey == "spp" else statistics.median(v[1] for v in vals)),
                           statistics.median(v[0] for v in vals)) for spp, vals in sorted(data[(sc, kind, m)].items())]
            xs = [p[0] for v in pts.values() for p in v if p[0] > 0]
            ys = [p[1] for v in pts.values() for p in v if p[1] > 0]
            if not xs or not ys:
                continue
            lx0, lx1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
            ly0, ly1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
            lx1, ly1 = max(lx1, lx0 + 1), max(ly1, ly0 + 1)
            X = lambda x: x0 + (math.log10(x) - lx0) / (lx1 - lx0) * pw
            Y = lambda y: y0 + ph - (math.log10(y) - ly0) / (ly1 - ly0) * ph
            parts.append(f'<rect x="{x0}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>')
            for e in range(lx0, lx1 + 1):
                parts.append(f'<text x="{X(10 ** e):.1f}" y="{y0 + ph + 12}" text-anchor="middle">1e{e}</text>')
            for e in range(ly0, ly1 + 1):
                parts.append(f'<text x="{x0 - 4}" y="{Y(10 ** e) + 3:.1f}" text-anchor="end">1e{e}</text>')
            xl = "samples per pixel" if xkey == "spp" else "render CPU ms (1 thread)"
            parts.append(f'<text x="{x0 + pw / 2}" y="{y0 + ph + 26}" text-anchor="middle">{xl}</text>')
            if ri == 0:
                title = f"{sc}, " + ("single scattering" if kind == "single" else "max_depth 8") + " — MSE"
                parts.append(f'<text x="{x0 + pw / 2}" y="{y0 - 6}" text-anchor="middle" font-weight="bold">{title}</text>')
            for mi, m in enumerate(methods):
                p = [(X(x), Y(y)) for x, y in pts[m] if x > 0 and y > 0]
                c = COLORS.get(m, "#000")
                parts.append('<polyline fill="none" stroke="%s" stroke-width="1.5" points="%s"/>'
                             % (c, " ".join(f"{a:.1f},{b:.1f}" for a, b in p)))
                parts.append(f'<text x="{x0 + pw - 4}" y="{y0 + 12 + 11 * mi}" text-anchor="end" fill="{c}">{m}</text>')
    parts.append("</svg>")
    open(svg, "w").write("\n".join(parts) + "\n")


if __name__ == "__main__":
    main()
