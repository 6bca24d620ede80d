#!/usr/bin/env python3
"""bench/brightness/table.py brightness.jsonl [more.jsonl ...] — markdown
table of mean luminance / pathtrace's per scene and lighting, as "all
orders / max_depth 1" (later files override earlier rows); "(w)" marks a
technique that warned about a light it ignores; bold = within ±15 %."""
import json
import sys

rows, techs, order = {}, [], []
for path in sys.argv[1:]:
    for line in open(path):
        line = line.strip()
        if not line:
            continue
        r = json.loads(line)
        key = (r["scene"], r["lighting"])
        if key not in rows:
            rows[key] = {}
            order.append(key)
        if r["technique"] not in techs:
            techs.append(r["technique"])
        rows[key][r["technique"]] = (r["ratio"], r.get("ratio1"), r["warnings"], r["reference"])
print("| scene | lights | pathtrace mean | " + " | ".join("`%s`" % t for t in techs) + " |")
print("|---|---|---|" + "---|" * len(techs))
for key in order:
    cells = []
    ref = None
    for t in techs:
        if t not in rows[key]:
            cells.append("-")
            continue
        ratio, ratio1, warn, ref = rows[key][t]
        c = "%.2f" % ratio
        if abs(ratio - 1) <= 0.15:
            c = "**%s**" % c
        if ratio1 is not None:
            c1 = "%.2f" % ratio1
            c += " / " + ("**%s**" % c1 if abs(ratio1 - 1) <= 0.15 else c1)
        if warn:
            c += " (w)"
        cells.append(c)
    print("| %s | %s | %.4g | %s |" % (key[0], key[1], ref, " | ".join(cells)))
