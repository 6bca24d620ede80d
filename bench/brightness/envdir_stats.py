#!/usr/bin/env python3
"""envdir_stats.py IMG REF REF1 SCENE LIGHTING NAME CPU — one JSON line: mean
luminance ratios against REF (all orders) and REF1 (single scattering) and
rel_mse (volux compare: mean over pixels and channels of (x - r)^2 / (r^2 + 0.01))."""
import array
import json
import sys


def load(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = array.array("f")
        a.frombytes(f.read(w * h * 12))
        if scale > 0:
            a.byteswap()
    return a


def lum(a):
    n = len(a) // 3
    return sum(0.2126 * a[3 * i] + 0.7152 * a[3 * i + 1] + 0.0722 * a[3 * i + 2] for i in range(n)) / n


def rel_mse(a, r):
    return sum((x - y) ** 2 / (y * y + 0.01) for x, y in zip(a, r)) / len(a)


img, ref, ref1 = (load(p) for p in sys.argv[1:4])
m, mr, mr1 = lum(img), lum(ref), lum(ref1)
print(json.dumps({"scene": sys.argv[4], "lighting": sys.argv[5], "technique": sys.argv[6],
                  "mean_luminance": round(m, 7), "ratio": round(m / mr, 4), "ratio1": round(m / mr1, 4),
                  "rel_mse": round(rel_mse(img, ref), 6), "rel_mse1": round(rel_mse(img, ref1), 6),
                  "cpu_s": float(sys.argv[7])}))
