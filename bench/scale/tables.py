#!/usr/bin/python3
"""Tables, fitted exponents and the log-log plot of bench/scale/run.sh output.

Usage: tables.py SCALE.jsonl [PLOT.svg|PLOT.png] (the plot needs gnuplot)
Prints a Markdown table per metric (prepare_ms, update_ms.tf + refine_ms.tf,
render_ms, render_cpu_ms, memory_bytes, memory estimate, peak_rss_bytes) by
technique and N, and the least-squares exponent of each metric against the
voxel count N³ over the sizes measured (a straight line in log-log), and
over 256³–1024³ alone (the issue's target range) when those were run."""
import json
import math
import os
import subprocess
import sys
import tempfile
from collections import defaultdict

rows = defaultdict(dict)  # (technique, n) -> metric -> value
for line in open(sys.argv[1]):
    try:
        d = json.loads(line)
    except json.JSONDecodeError:  # the driver's own exit rows of older runs
        continue
    if "n" not in d:
        continue
    key = (d["technique"], d["n"])
    rows[key][d["metric"]] = d["value"]
    if d["metric"] == "prepare_ms":
        rows[key]["load"] = d.get("load")

techs = []
for t, n in rows:
    if t not in techs:
        techs.append(t)
sizes = sorted({n for _, n in rows})


def update_ms(m):
    if "update_ms.tf" not in m:
        return None
    return m["update_ms.tf"] + m.get("refine_ms.tf", 0.0)


metrics = [
    ("prepare_ms", "prepare (ms, wall)", lambda m: m.get("prepare_ms")),
    ("update_ms", "TF edit: update + deferred refine (ms, wall)", update_ms),
    ("render_ms", "frame, 256², 1 spp (ms, wall)", lambda m: m.get("render_ms")),
    ("render_cpu_ms", "frame, 256², 1 spp (ms, CPU of all threads)", lambda m: m.get("render_cpu_ms")),
    ("memory_bytes", "technique memory_bytes (MB)", lambda m: m.get("memory_bytes") and m["memory_bytes"] / 1e6),
    ("estimate", "its estimate (MB)", lambda m: m.get("memory_estimate_bytes") and m["memory_estimate_bytes"] / 1e6),
    ("peak_rss", "peak RSS of the process (MB)", lambda m: m.get("peak_rss_bytes") and m["peak_rss_bytes"] / 1e6),
]


def fit(points):
    """Least-squares slope of log(value) against log(N³)."""
    pts = [(math.log(n ** 3), math.log(v)) for n, v in points if v and v > 0]
    if len(pts) < 2:
        return None
    mx = sum(x for x, _ in pts) / len(pts)
    my = sum(y for _, y in pts) / len(pts)
    sxx = sum((x - mx) ** 2 for x, _ in pts)
    return sum((x - mx) * (y - my) for x, y in pts) / sxx if sxx > 0 else None


exponents = {}
upper = [n for n in sizes if n >= 256]
for key, title, get in metrics:
    print(f"\n**{title}**\n")
    two = len(upper) >= 2 and len(upper) < len(sizes)
    print("| technique | " + " | ".join(f"{n}³" for n in sizes) + " | exponent vs N³ |" +
          (f" {upper[0]}³–{upper[-1]}³ |" if two else ""))
    print("|---|" + "---|" * (len(sizes) + 1 + (1 if two else 0)))
    for t in techs:
        vals = [get(rows[(t, n)]) if (t, n) in rows else None for n in sizes]
        e = fit([(n, v) for n, v in zip(sizes, vals) if v is not None])
        eu = fit([(n, v) for n, v in zip(sizes, vals) if v is not None and n >= 256])
        exponents[(key, t)] = e
        cells = ["—" if v is None else (f"{v:.3g}" if v < 1000 else f"{v:.0f}") for v in vals]
        fmt = lambda x: "—" if x is None else f"{x:.2f}"
        print(f"| {t} | " + " | ".join(cells) + f" | {fmt(e)} |" + (f" {fmt(eu)} |" if two else ""))

loads = [m.get("load") for m in rows.values() if m.get("load")]
if loads:
    print(f"\nload average during the runs: {min(loads):.1f}–{max(loads):.1f} (2 cores)")

if len(sys.argv) > 2:
    # four log-log panels through gnuplot (as tools/plot/convergence.sh)
    out = sys.argv[2]
    panels = [metrics[0], metrics[1], metrics[3], metrics[6]]
    with tempfile.TemporaryDirectory() as tmp:
        term = "png size 1600,420" if out.endswith(".png") else 'svg size 1600,420 dynamic font "sans,10"'
        script = [f"set terminal {term}",
                  f"set output '{out}'", "set multiplot layout 1,4", "set logscale xy", "set grid",
                  "set xlabel 'voxels'", "set key top left font ',8'", "set format x '10^{%L}'"]
        for p, (key, title, get) in enumerate(panels):
            plots = []
            for t in techs:
                pts = [(n ** 3, get(rows[(t, n)])) for n in sizes if (t, n) in rows and get(rows[(t, n)])]
                if not pts:
                    continue
                f = os.path.join(tmp, f"{p}_{t}.dat")
                with open(f, "w") as fh:
                    fh.writelines(f"{x} {y}\n" for x, y in pts)
                plots.append(f"'{f}' using 1:2 with linespoints title '{t}'")
            script.append(f"set title '{title}'")
            script.append("plot " + ", ".join(plots) if plots else "clear")
        script.append("unset multiplot")
        subprocess.run(["gnuplot"], input="\n".join(script) + "\n", text=True, check=True)
