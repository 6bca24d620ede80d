#!/usr/bin/env python3
"""bench/guided/equal_time.py OUT_DIR [SPP] — the table of equal_time.sh's runs.

Per scene and seed, at SPP samples per pixel (default: the largest run):
MSE against the pathtrace reference and render CPU ms (one thread), for
  single:   two_step vs environment (guided's strategies, max_depth 1)
  multiple: guided (guide_depth 0 = every event, 1 = the paper's first) vs
            pathtrace, max_depth 8.
Equal-time MSE ratio = (MSE_a * cpu_a) / (MSE_b * cpu_b): for unbiased
estimators MSE ~ 1/spp ~ 1/time. "+prep" adds each run's preparation
(volume load, environment tables, visibility grid) to its render time at
that spp. Medians over seeds.
"""
import json
import statistics
import sys
from collections import defaultdict


def load(path, spp):
    runs = defaultdict(dict)  # (scene, kind, method, seed) -> fields
    for line in open(path):
        o = json.loads(line)
        parts = o["label"].split()
        key = (parts[0], parts[1], parts[2], parts[4])
        if o["metric"] == "prepare_cpu_ms":
            runs[key]["prep"] = o["value"]
        elif o["metric"] == "convergence.mse":
            runs[key].setdefault("by_spp", {})[o["spp"]] = (o["value"], o["cpu_ms"])
    out = {}
    for k, r in runs.items():
        s = spp or max(r["by_spp"])
        if s in r["by_spp"]:
            out[k] = (r["by_spp"][s][0], r["by_spp"][s][1], r.get("prep", 0.0), s)
    return out


def table(runs, kind, base, others):
    scenes = sorted({k[0] for k in runs if k[1] == kind}, key=lambda s: (not s.startswith("canopy"), s))
    print("| scene | method | spp | MSE (median) | render CPU ms | MSE ratio, equal spp | CPU ratio | "
          "**equal-time MSE ratio** | equal time +prep |")
    print("|---|---|---|---|---|---|---|---|---|")
    for sc in scenes:
        seeds = sorted({k[3] for k in runs if k[0] == sc and k[1] == kind})
        for m in [base] + others:
            rows = [runs.get((sc, kind, m, s)) for s in seeds]
            bases = [runs.get((sc, kind, base, s)) for s in seeds]
            pairs = [(a, b) for a, b in zip(rows, bases) if a and b]
            if not pairs:
                continue
            mse = statistics.median(a[0] for a, _ in pairs)
            cpu = statistics.median(a[1] for a, _ in pairs)
            if m == base:
                print(f"| {sc} | {m} | {pairs[0][0][3]} | {mse:.3g} | {cpu:.0f} | 1 | 1 | 1 | 1 |")
                continue
            r_mse = statistics.median(a[0] / b[0] for a, b in pairs)
            r_cpu = statistics.median(a[1] / b[1] for a, b in pairs)
            r_et = statistics.median(a[0] * a[1] / (b[0] * b[1]) for a, b in pairs)
            r_etp = statistics.median(a[0] * (a[1] + a[2]) / (b[0] * (b[1] + b[2])) for a, b in pairs)
            print(f"| {sc} | {m} | {pairs[0][0][3]} | {mse:.3g} | {cpu:.0f} | {r_mse:.2f} | {r_cpu:.2f} | "
                  f"**{r_et:.2f}** | {r_etp:.2f} |")
    print(f"\n({len(seeds)} seeds)\n")


def main():
    out = sys.argv[1]
    spp = int(sys.argv[2]) if len(sys.argv) > 2 else None
    print("(a) single scattering: two_step vs environment\n")
    table(load(out + "/single.jsonl", spp), "single", "environment", ["two_step"])
    print("(b) max_depth 8: guided vs pathtrace\n")
    table(load(out + "/multiple.jsonl", spp), "multiple", "pathtrace", ["guided_depth0", "guided_depth1"])


if __name__ == "__main__":
    main()
