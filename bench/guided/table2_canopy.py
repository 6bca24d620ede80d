#!/usr/bin/env python3
"""bench/guided/table2_canopy.py OUT_DIR — Table 2 from table2_canopy.sh's
table2.jsonl: visibility-grid CPU ms (median of repeats, one thread), its
cost relative to the unfiltered sweep, and the two_step image's MSE at the
largest spp (median over seeds) relative to the unfiltered sweep's."""
import json
import statistics
import sys
from collections import defaultdict

vis, mse = {}, defaultdict(list)
for line in open(sys.argv[1] + "/table2.jsonl"):
    o = json.loads(line)
    label = o["label"].split(" seed ")[0]
    if o["metric"] == "visibility_cpu_ms":
        vis[label] = o["value"]
    elif o["metric"] == "convergence.mse":
        mse[(label, o["label"])].append((o["spp"], o["value"]))
best = defaultdict(list)
for (label, _), v in mse.items():
    best[label].append(max(v)[1])
base_v, base_m = vis.get("unfiltered"), statistics.median(best["unfiltered"]) if best["unfiltered"] else None
print("| visibility | grid CPU ms | × unfiltered | MSE two_step 64 spp (median) | × unfiltered |")
print("|---|---|---|---|---|")
for label in vis:
    m = statistics.median(best[label]) if best[label] else float("nan")
    print(f"| {label} | {vis[label]:.0f} | {vis[label] / base_v:.2f} | {m:.3g} | {m / base_m:.2f} |")
