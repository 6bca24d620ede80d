#!/usr/bin/env python3
"""bench/ambient/offset_table.py OUTDIR/offset.jsonl — the markdown table of
docs/techniques/ambient.md §8: rel_mse vs pathtrace per scene (and radius)
for single, ao and ambient's four camera offsets; the best per row bold."""
import json
import sys

rows = {}
order = []
for line in open(sys.argv[1]):
    line = line.strip()
    if not line:
        continue
    r = json.loads(line)
    key = r["scene"]
    if key not in rows:
        rows[key] = {}
        order.append(key)
    col = r["technique"] if r["technique"] != "ambient" else "ambient " + r["variant"]
    rows[key].setdefault(r["radius"], {})[col] = r["rel_mse"]

cols = ["single", "ao", "ambient constant", "ambient offset0", "ambient adaptive", "ambient adaptive_once",
        "ambient fill"]
print("| scene | r | `single` | `ao` | `ambient` constant (Eq. 20) | `ambient` offset 0 | `ambient` adaptive (old default) "
      "| adaptive + albedo_once | `ambient` fill + albedo_once (default) |")
print("|---|---|---|---|---|---|---|---|---|")
for scene in order:
    by_r = rows[scene]
    single = by_r.get(0, {}).get("single")
    for radius in sorted(k for k in by_r if k != 0):
        v = dict(by_r[radius])
        if single is not None:
            v["single"] = single
        best = min(x for x in v.values())
        cells = []
        for c in cols:
            x = v.get(c)
            cells.append("-" if x is None else ("**%.4g**" % x if x == best else "%.4g" % x))
        print("| %s | %g | %s |" % (scene, radius, " | ".join(cells)))
