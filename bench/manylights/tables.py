#!/usr/bin/env python3
"""Markdown tables from bench/manylights results.

  tables.py table2 OUT.jsonl [SIZE]     Table 2 analogue (ms; CPU ms in brackets)
"""
import json
import sys
from collections import defaultdict


def load(path):
    with open(path) as f:
        return [json.loads(l) for l in f if l.strip().startswith("{")]


def table2(rows, size):
    size = int(size)
    v = defaultdict(dict)
    for r in rows:
        key = (r["scene"].split("/")[-1].replace(".json", ""), r["vl_count"])
        v[key][(r["transmittance"], r["metric"])] = r
    print("| scene | # VLs | RM | AVSM creation | point | trilinear | RM / point |")
    print("|---|---|---|---|---|---|---|")
    for (scene, n) in sorted(v, key=lambda k: (k[0], k[1])):
        d = v[(scene, n)]

        def render(tm):
            r = d.get((tm, "render_ms"))
            c = d.get((tm, "render_cpu_ms"))
            if not r:
                return None, None, ""
            scale = (size / r["size"]) ** 2
            return r["value"] * scale, c["value"] * scale if c else None, " (scaled)" if scale != 1 else ""

        rm, rm_cpu, rm_note = render("raymarch")
        pt, pt_cpu, _ = render("avsm")
        tri, tri_cpu, _ = render("avsm_linear")
        create = d.get(("avsm", "avsm_build_ms"))
        fmt = lambda a, b: "—" if a is None else ("%.0f [%.0f]" % (a, b) if b is not None else "%.0f" % a)
        ratio = "%.1f× [%.1f×]" % (rm / pt, rm_cpu / pt_cpu) if rm and pt and rm_cpu and pt_cpu else "—"
        print("| %s | %d | %s%s | %s | %s | %s | %s |" % (scene, n, fmt(rm, rm_cpu), rm_note,
                                                         "%.0f" % create["value"] if create else "—",
                                                         fmt(pt, pt_cpu), fmt(tri, tri_cpu), ratio))


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    if sys.argv[1] == "table2":
        table2(load(sys.argv[2]), sys.argv[3] if len(sys.argv) > 3 else 512)
    else:
        raise SystemExit(__doc__)
