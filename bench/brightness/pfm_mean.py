#!/usr/bin/env python3
"""pfm_mean.py IMG.pfm — mean linear luminance (Rec. 709 weights) of a PFM."""
import array
import sys

with open(sys.argv[1], "rb") as f:
    assert f.readline().strip() == b"PF"
    w, h = map(int, f.readline().split())
    scale = float(f.readline())
    a = array.array("f")
    a.frombytes(f.read(w * h * 12))
    if scale > 0:
        a.byteswap()
n = w * h
print("%.6g" % (sum(0.2126 * a[3 * i] + 0.7152 * a[3 * i + 1] + 0.0722 * a[3 * i + 2] for i in range(n)) / n))
