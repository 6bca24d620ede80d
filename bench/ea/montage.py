#!/usr/bin/env python3
"""Side-by-side PNG of linear PFM images (Python standard library only).

  montage.py OUT.png ROW [ROW ...]      ROW = A.pfm,B.pfm[,...]  (one image row each)

Every PFM is shown with the sRGB transfer curve (no exposure), clamped to
8 bits, 2-pixel grey gaps. A cell written `diff:A.pfm:B.pfm:S` shows the
largest channel |A - B| per pixel as grey, white = S.
"""
import struct
import sys
import zlib


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise SystemExit("%s: not an RGB PFM" % path)
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read(w * h * 12)
    v = struct.unpack(("<" if scale < 0 else ">") + "%df" % (w * h * 3), data)
    rows = [v[3 * w * y: 3 * w * (y + 1)] for y in range(h)]
    return w, h, rows[::-1]  # PFM rows are bottom-up


def srgb(x):
    x = min(max(x, 0.0), 1.0)
    x = 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055
    return int(round(255 * x))


def cell(spec):
    if spec.startswith("diff:"):
        _, a, b, s = spec.split(":")
        w, h, ra = read_pfm(a)
        _, _, rb = read_pfm(b)
        scale = float(s)
        out = []
        for y in range(h):
            row = []
            for x in range(w):
                d = max(abs(ra[y][3 * x + c] - rb[y][3 * x + c]) for c in range(3))
                g = int(round(255 * min(d / scale, 1.0)))
                row += [g, g, g]
            out.append(row)
        return w, h, out
    w, h, rows = read_pfm(spec)
    return w, h, [[srgb(v) for v in r] for r in rows]


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    grid = [[cell(s) for s in row.split(",")] for row in sys.argv[2:]]
    gap = 2
    width = max(sum(c[0] for c in r) + gap * (len(r) + 1) for r in grid)
    height = sum(max(c[1] for c in r) for r in grid) + gap * (len(grid) + 1)
    img = [[96] * (3 * width) for _ in range(height)]
    y0 = gap
    for r in grid:
        x0 = gap
        for w, h, px in r:
            for y in range(h):
                img[y0 + y][3 * x0: 3 * (x0 + w)] = px[y]
            x0 += w + gap
        y0 += max(c[1] for c in r) + gap
    raw = b"".join(b"\0" + bytes(row) for row in img)

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(sys.argv[1], "wb") as f:
        f.write(png)


main()
