#!/usr/bin/env python3
"""bench/sampler/measure.py — variance·spp of `pathtrace` with sampler
"sobol" vs "independent" (issue 33, docs/techniques/pathtrace.md "Sampling").

  VOLUX=build/volux VOLUX_DATA=../shared/data \
    python3 bench/sampler/measure.py [--seeds K] [--size N] [--spp 4,16,64] \
        [--technique pathtrace] SCENE.json... > out.txt

For each scene, sampler and spp: K renders with seeds 1..K (PFM, 1 thread
each pair side by side), the per-pixel variance across the seeds (unbiased,
K − 1), its mean over the pixels (all, and the pixels whose mean differs
from the background: "medium") times spp, and the CPU time per spp (median
over the seeds, from the process's user+sys time). Prints one line per
(scene, spp) with both samplers and the ratio sobol / independent.
No numpy: PFMs are read with the array module.
"""
import argparse, array, os, resource, statistics, subprocess, sys, tempfile


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = array.array("f")
        data.frombytes(f.read())
    if scale > 0:
        data.byteswap()
    assert kind == b"PF" and len(data) == 3 * w * h
    return data


def render(volux, scene, out, technique, sampler, spp, seed, size):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([volux, "render", scene, "-o", out, "--technique", technique, "--spp", str(spp),
                    "--seed", str(seed), "--width", str(size), "--height", str(size), "--threads", "1",
                    "--quiet", "--set", 'techniques.%s.sampler="%s"' % (technique, sampler)], check=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def stats(images, spp):
    n = len(images[0]) // 3
    K = len(images)
    var_all = var_med = 0.0
    n_med = 0
    for p in range(n):
        vs = 0.0
        bg = True
        for c in range(3):
            xs = [im[3 * p + c] for im in images]
            m = sum(xs) / K
            vs += sum((x - m) ** 2 for x in xs) / (K - 1)
            if any(x != xs[0] for x in xs):
                bg = False
        vs /= 3.0
        var_all += vs
        if not bg:
            var_med += vs
            n_med += 1
    return var_all / n * spp, (var_med / max(n_med, 1)) * spp


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", default="4,16,64")
    ap.add_argument("--technique", default="pathtrace")
    a = ap.parse_args()
    volux = os.environ.get("VOLUX", "build/volux")
    tmp = tempfile.mkdtemp(prefix="sampler_")
    print("# scene spp | var*spp indep | var*spp sobol | ratio | medium-pixel ratio | CPU ms/spp indep | sobol")
    for scene in a.scenes:
        for spp in map(int, a.spp.split(",")):
            res = {}
            ims = {"independent": [], "sobol": []}
            cpu = {"independent": [], "sobol": []}
            for seed in range(1, a.seeds + 1):
                for smp in ("independent", "sobol"):  # side by side: same load
                    out = os.path.join(tmp, "%s_%d.pfm" % (smp, seed))
                    cpu[smp].append(render(volux, scene, out, a.technique, smp, spp, seed, a.size) * 1000.0 / spp)
                    ims[smp].append(read_pfm(out))
            for smp in ims:
                res[smp] = stats(ims[smp], spp)
            i, s = res["independent"], res["sobol"]
            print("%s %d | %.5g | %.5g | %.3f | %.3f | %.2f | %.2f" % (
                os.path.basename(scene), spp, i[0], s[0], s[0] / i[0], s[1] / i[1],
                statistics.median(cpu["independent"]), statistics.median(cpu["sobol"])), flush=True)


if __name__ == "__main__":
    main()
