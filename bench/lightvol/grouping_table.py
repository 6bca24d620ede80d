#!/usr/bin/env python3
"""bench/lightvol/grouping_table.py TIMING.jsonl [ERROR.txt] — the grouping comparison
table of docs/techniques/lightvol.md (positional_grouping voxel vs center): CPU-ms
medians of entire sequential / coherent updates, their ratio, one light's state
change, and rel_mse vs pathtrace single scattering (f = 0, scale 1)."""
import json, sys
from collections import OrderedDict

rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
t = OrderedDict()
for r in rows:
    if "metric" not in r:
        continue
    name = r["scene"].split("/")[-1][len("lightvol_"):-len(".json")]
    t.setdefault((name, r["f"]), {}).setdefault(r["grouping"], {})[r["metric"]] = r.get("cpu_ms", r["value"])
err = {}
if len(sys.argv) > 2:
    for line in open(sys.argv[2]):
        scene, kind, js = line.split(" ", 2)
        err[(scene[len("lightvol_"):], kind)] = json.loads(js)["rel_mse"]
print("| setup | f | grouping | entire sequential | entire coherent | coh/seq | state change | rel_mse vs pathtrace (f = 0) |")
print("|---|---|---|---|---|---|---|---|")
for (name, f), g in t.items():
    for kind in ("voxel", "center"):
        m = g.get(kind)
        if not m:
            continue
        seq, coh = m["update_ms.full_sequential"], m["update_ms.full_coherent"]
        e = err.get((name, kind))
        es = "%.4f (noise %.4f)" % (e, err[(name, "noise")]) if e is not None and f == 0 else ""
        print("| %s | %g | %s | %.0f ms | %.0f ms | %.2f | %.0f ms | %s |" % (name, f, kind, seq, coh, coh / seq,
                                                                           m["update_ms.light"], es))
