#!/usr/bin/env python3
"""bench/guided/table2.py OUT_DIR/table2.jsonl — Table 2 from run.sh's table2
phase: per scene and configuration the visibility grid's CPU time (the
instance's preparation minus that of `environment`, which builds no grid)
and the two_step MSE at the largest spp (median over the seeds of one
instance), both relative to the unfiltered sweep (MSE ratios paired by seed).
"""
import json
import statistics
import sys
from collections import defaultdict

prep, mse = {}, defaultdict(dict)
for line in open(sys.argv[1]):
    o = json.loads(line)
    scene, cfg = o["label"].split(maxsplit=1)
    if o["metric"] == "prepare_cpu_ms":
        prep[(scene, cfg)] = o["value"]
    elif o["metric"] == "convergence.mse":
        d = mse[(scene, cfg)]
        if o["spp"] >= d.get(o["seed"], (0, 0))[0]:
            d[o["seed"]] = (o["spp"], o["value"])
print("| scene | configuration | grid CPU ms | × unfiltered | MSE (median) | MSE × unfiltered (paired) |")
print("|---|---|---|---|---|---|")
for scene in sorted({k[0] for k in prep}):
    base_prep = prep.get((scene, "environment"), 0.0)
    ref = mse.get((scene, "unfiltered"), {})
    grid_u = prep.get((scene, "unfiltered"), float("nan")) - base_prep
    for (sc, cfg) in [k for k in prep if k[0] == scene]:
        g = prep[(sc, cfg)] - base_prep
        m = mse.get((sc, cfg), {})
        ratios = [m[s][1] / ref[s][1] for s in m if s in ref]
        print(f"| {sc} | {cfg} | {g:.0f} | {g / grid_u:.2f} | "
              f"{statistics.median(v for _, v in m.values()) if m else float('nan'):.4g} | "
              f"{statistics.median(ratios) if ratios else float('nan'):.3f} ({len(ratios)} seeds) |")
