#!/usr/bin/env python3
"""bench/ambient/summarize.py RESULTS.jsonl [ERRORS.jsonl] — the Markdown
version of Ament et al. 2013, Table 1 (update and render times per
technique) from `volux bench --json` lines, plus rel_mse against pathtrace
when compare.sh's output is given."""
import json
import sys
from collections import defaultdict

TECHS = ["ea", "ao", "single", "ambient"]


def main():
    rows = defaultdict(dict)
    for line in open(sys.argv[1]):
        line = line.strip()
        if not line.startswith("{"):
            continue
        r = json.loads(line)
        scene = r["scene"].rsplit("/", 1)[-1].replace(".json", "")
        rows[scene][(r["technique"], r["metric"])] = r["value"]
    errors = defaultdict(dict)
    if len(sys.argv) > 2:
        for line in open(sys.argv[2]):
            if line.startswith("{"):
                r = json.loads(line)
                errors[r["scene"]][r["technique"]] = r["rel_mse"]

    def cell(scene, metric, fmt="%.1f"):
        vals = []
        for t in TECHS:
            v = rows[scene].get((t, metric))
            vals.append("-" if v is None else fmt % v)
        return "/".join(vals)

    print("| scene | TF change [ms] | PF change [ms] | LS change [ms] | camera [ms] | render [ms] | memory [MB] |")
    print("|---|---|---|---|---|---|---|")
    for scene in rows:
        mem = "/".join("-" if rows[scene].get((t, "memory_bytes")) is None
                       else "%.0f" % (rows[scene][(t, "memory_bytes")] / 2**20) for t in TECHS)
        print("| %s | %s | %s | %s | %s | %s | %s |" % (
            scene, cell(scene, "update_ms.tf"), cell(scene, "update_ms.phase"), cell(scene, "update_ms.light"),
            cell(scene, "update_ms.camera", "%.3f"), cell(scene, "render_ms"), mem))
    print("\nValues are ea/ao/single/ambient.")
    for scene in rows:
        g = rows[scene]
        tf, pf, ls = (g.get(("ambient", m)) for m in ("update_ms.tf", "update_ms.phase", "update_ms.light"))
        ra, rs = g.get(("ambient", "render_ms")), g.get(("single", "render_ms"))
        ll = g.get(("ambient", "update_ms.light_last"))
        if tf and pf and ls and ra and rs:
            print("- %s: ambient PF/TF = %.3f, LS/TF = %.3f%s (target <= 0.15); render ambient/single = %.2f "
                  "(target <= 2)" % (scene, pf / tf, ls / tf,
                                     ", last light LS/TF = %.3f" % (ll / tf) if ll else "", ra / rs))
    if errors:
        cols = ["ao", "single", "ambient", "ambient_o0"]
        print("\n| scene | " + " | ".join("rel_mse " + c for c in cols) + " |")
        print("|---" * (len(cols) + 1) + "|")
        for scene, e in errors.items():
            print("| %s | %s |" % (scene, " | ".join("%.4g" % e[t] if t in e else "-" for t in cols)))


if __name__ == "__main__":
    main()
