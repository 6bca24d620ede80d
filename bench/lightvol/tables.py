#!/usr/bin/env python3
"""bench/lightvol/tables.py RESULTS.jsonl — markdown tables for docs/techniques/lightvol.md
(Table 1 mirror with the three targets, and the scaling test)."""
import json, sys
from collections import OrderedDict

rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
notes = [r for r in rows if "note" in r]
data = [r for r in rows if "metric" in r]
table = OrderedDict()
for r in data:
    if r["metric"].startswith("scaling."):
        continue
    key = (r["config"], r["scale"])
    table.setdefault(key, {})[r["metric"]] = r

def v(m, k, cpu=True):
    r = m.get(k)
    if r is None:
        return float("nan")
    return r.get("cpu_ms", r["value"]) if cpu else r["value"]

print("| setup | scale | full sequential | full coherent | coh/seq (≤ 0.67) | state change (N lights) | change/coh (≤ 2/N+0.1) | toggle | toggle/change (≤ 0.5) | render | memory |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for (config, scale), m in table.items():
    n = {"2": 2, "3": 3, "4": 4}.get(config.split(", ")[1].split(" ")[0], 0)
    seq, coh = v(m, "update_ms.full_sequential"), v(m, "update_ms.full_coherent")
    ch, tg = v(m, "update_ms.light"), v(m, "update_ms.light_toggle")
    rd = v(m, "render_ms")
    mem = m["memory_bytes"]["value"] / 2**20 if "memory_bytes" in m else float("nan")
    lim = 2.0 / n + 0.1 if n else float("nan")
    ok = lambda x, t: "**%.2f** ✓" % x if x <= t else "%.2f ✗" % x
    print("| %s | %s | %.0f ms | %.0f ms | %s | %.0f ms (N=%d) | %s (≤ %.2f) | %.0f ms | %s | %.0f ms | %.0f MiB |" % (
        config, scale, seq, coh, ok(coh / seq, 0.67), ch, n, ok(ch / coh, lim), lim, tg, ok(tg / ch, 0.5), rd, mem))

scal = OrderedDict()
for r in data:
    if r["metric"].startswith("scaling."):
        scal.setdefault(r["config"], OrderedDict()).setdefault(r["lights"], {})[r["metric"].split("_")[-1]] = r["cpu_ms"]
for config, pts in scal.items():
    print("\n%s (CPU ms for an entire update):\n" % config)
    print("| lights | sequential | coherent |")
    print("|---|---|---|")
    for n, d in pts.items():
        print("| %d | %.1f | %.1f |" % (n, d.get("sequential", float("nan")), d.get("coherent", float("nan"))))
    ns = list(pts.keys())
    a, b = ns[0], ns[-1]
    ms = (pts[b]["sequential"] - pts[a]["sequential"]) / (b - a)
    mc = (pts[b]["coherent"] - pts[a]["coherent"]) / (b - a)
    print("\nmarginal per added light: sequential %.2f ms, coherent %.2f ms, ratio %.2f (target ≤ 0.10: %s)" % (
        ms, mc, mc / ms, "met" if mc / ms <= 0.1 else "not met"))
for n in notes:
    print("\n<!-- %s load %s %s -->" % (n["note"], n["load"], n["date"]))
