#!/usr/bin/env python3
"""bench/guided/pairs.py FILE.jsonl BASE [SPP] — paired equal-spp / equal-time
ratios of bench_guided `converge` runs labelled "<scene> <method ...> seed <n>"
(env_resolution.sh, continuation.sh).

Per scene and method, at SPP samples per pixel (default: the largest run):
median over seeds of MSE, render CPU ms, and the ratios against the method
whose label starts with BASE on the same scene and seed: MSE (equal spp),
CPU per sample, and equal-time MSE = (MSE * CPU) / (MSE * CPU)_base (for
unbiased estimators MSE ~ 1/time).
"""
import json
import statistics
import sys
from collections import defaultdict


def main():
    path, base = sys.argv[1], sys.argv[2]
    want = int(sys.argv[3]) if len(sys.argv) > 3 else None
    runs = defaultdict(dict)  # (scene, method, seed) -> spp -> (mse, cpu)
    for line in open(path):
        o = json.loads(line)
        if o["metric"] != "convergence.mse":
            continue
        words = o["label"].split()
        scene, method, seed = words[0], " ".join(words[1:-2]), words[-1]
        runs[(scene, method, seed)][o["spp"]] = (o["value"], o["cpu_ms"])
    scenes = sorted({k[0] for k in runs})
    print("| scene | method | spp | MSE | render CPU ms | MSE ratio (equal spp) | CPU ratio | equal-time MSE ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for sc in scenes:
        methods = sorted({k[1] for k in runs if k[0] == sc}, key=lambda m: (not m.startswith(base), m))
        bm = next((m for m in methods if m.startswith(base)), None)
        for m in methods:
            seeds = sorted(k[2] for k in runs if k[0] == sc and k[1] == m)
            spp = want or max(max(runs[(sc, m, s)]) for s in seeds)
            mse, cpu, rm, rc, rt = [], [], [], [], []
            for s in seeds:
                a = runs[(sc, m, s)].get(spp)
                b = runs.get((sc, bm, s), {}).get(spp)
                if not a:
                    continue
                mse.append(a[0])
                cpu.append(a[1])
                if b:
                    rm.append(a[0] / b[0])
                    rc.append(a[1] / b[1])
                    rt.append(a[0] * a[1] / (b[0] * b[1]))
            med = statistics.median
            print(f"| {sc} | {m} | {spp} | {med(mse):.4g} | {med(cpu):.0f} | "
                  + (f"{med(rm):.3f} | {med(rc):.3f} | **{med(rt):.3f}** |" if rm else "— | — | — |")
                  + f" ({len(mse)} seeds)")


if __name__ == "__main__":
    main()
