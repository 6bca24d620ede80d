#!/usr/bin/env python3
"""Small PFM utilities for the manylights benchmarks (standard library only:
the machines have no numpy/ImageMagick).

  pfmtool.py png OUT.png [--exposure E] [--label] IN.pfm...   side by side, sRGB tone-mapped
  pfmtool.py relerr A.pfm REF.pfm OUT.png [--max M]           |A-REF|/REF per pixel (luminance),
                                                              0 black .. M white; prints mean
  pfmtool.py diffstats A.pfm B.pfm                           mean |A-B|/B over pixels with B > 1e-3·max
  pfmtool.py add A.pfm B.pfm OUT.pfm                          A + B
"""
import math
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
    fmt = ("<" if scale < 0 else ">") + "%df" % (w * h * 3)
    v = struct.unpack(fmt, data)
    rows = [v[(h - 1 - y) * w * 3:(h - y) * w * 3] for y in range(h)]  # PFM rows are bottom-up
    return w, h, [x for r in rows for x in r]


def write_pfm(path, w, h, px):
    rows = [px[y * w * 3:(y + 1) * w * 3] for y in range(h)][::-1]
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1\n" % (w, h))
        f.write(struct.pack("<%df" % (w * h * 3), *[x for r in rows for x in r]))


def srgb(x):
    x = max(0.0, min(1.0, x))
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


def write_png(path, w, h, rgb8):
    raw = b"".join(b"\x00" + bytes(rgb8[y * w * 3:(y + 1) * w * 3]) for y in range(h))

    def chunk(t, d):
        c = struct.pack(">I", len(d)) + t + d
        return c + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def lum(px, i):
    return 0.2126 * px[3 * i] + 0.7152 * px[3 * i + 1] + 0.0722 * px[3 * i + 2]


def cmd_png(args):
    out, exposure, files = args[0], 0.0, []
    i = 1
    while i < len(args):
        if args[i] == "--exposure":
            exposure = float(args[i + 1])
            i += 2
        else:
            files.append(args[i])
            i += 1
    imgs = [read_pfm(f) for f in files]
    gap = 2
    W = sum(w for w, _, _ in imgs) + gap * (len(imgs) - 1)
    H = max(h for _, h, _ in imgs)
    out8 = [255] * (W * H * 3)
    k = 2.0 ** exposure
    x0 = 0
    for w, h, px in imgs:
        for y in range(h):
            for x in range(w):
                for c in range(3):
                    out8[(y * W + x0 + x) * 3 + c] = int(srgb(px[(y * w + x) * 3 + c] * k) * 255 + 0.5)
        x0 += w + gap
    write_png(out, W, H, out8)


def cmd_relerr(args):
    a, ref, out = args[0], args[1], args[2]
    m = float(args[4]) if len(args) > 4 and args[3] == "--max" else 0.2
    w, h, pa = read_pfm(a)
    _, _, pr = read_pfm(ref)
    peak = max(lum(pr, i) for i in range(w * h))
    out8, errs = [], []
    for i in range(w * h):
        r = lum(pr, i)
        if r > 1e-3 * peak:
            e = abs(lum(pa, i) - r) / r
            errs.append(e)
        else:
            e = 0.0
        v = int(min(e / m, 1.0) * 255 + 0.5)
        out8 += [v, v, v]
    write_png(out, w, h, out8)
    print("mean_rel_err %.6g over %d pixels (max shown %.3g)" % (sum(errs) / max(len(errs), 1), len(errs), m))


def cmd_diffstats(args):
    w, h, pa = read_pfm(args[0])
    _, _, pb = read_pfm(args[1])
    peak = max(lum(pb, i) for i in range(w * h))
    errs = [abs(lum(pa, i) - lum(pb, i)) / lum(pb, i) for i in range(w * h) if lum(pb, i) > 1e-3 * peak]
    print("%.6g" % (sum(errs) / max(len(errs), 1)))


def cmd_add(args):
    w, h, pa = read_pfm(args[0])
    _, _, pb = read_pfm(args[1])
    write_pfm(args[2], w, h, [x + y for x, y in zip(pa, pb)])


if __name__ == "__main__":
    cmds = {"png": cmd_png, "relerr": cmd_relerr, "diffstats": cmd_diffstats, "add": cmd_add}
    if len(sys.argv) < 3 or sys.argv[1] not in cmds:
        raise SystemExit(__doc__)
    cmds[sys.argv[1]](sys.argv[2:])
