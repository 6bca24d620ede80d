#!/usr/bin/python3
"""4x-zoom crops for docs/techniques/sh.md (issue 28).

  crops.py OUT.png X0 Y0 SIZE ROW1 [ROW2 ...]
  ROW = comma-separated PFMs (one row of the montage; the first PFM of the
  row sets the exposure: its 99.5th percentile maps to white).

Crops SIZE x SIZE pixels at (X0, Y0) (top-left, image rows top-down) of each
PFM, scales them 4x (nearest), tone-maps with the sRGB curve and writes one
PNG with the crops side by side (2 px gaps). Only numpy and zlib.
"""
import struct
import sys
import zlib

import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise SystemExit("%s: not an RGB PFM" % path)
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(w * h * 12), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return data[::-1].astype(np.float64)


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def write_png(path, rgb8):
    h, w, _ = rgb8.shape
    raw = b"".join(b"\x00" + rgb8[y].tobytes() for y in range(h))

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main():
    out, x0, y0, size = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    rows = []
    for row in sys.argv[5:]:
        paths = row.split(",")
        imgs = [read_pfm(p)[y0:y0 + size, x0:x0 + size] for p in paths]
        white = np.percentile(imgs[0], 99.5) or 1.0
        tiles = [np.kron(srgb(im / white), np.ones((4, 4, 1))) for im in imgs]
        gap = np.ones((4 * size, 2, 3))
        line = tiles[0]
        for t in tiles[1:]:
            line = np.concatenate([line, gap, t], axis=1)
        rows.append(line)
    width = max(r.shape[1] for r in rows)
    rows = [np.concatenate([r, np.ones((r.shape[0], width - r.shape[1], 3))], axis=1) for r in rows]
    img = rows[0]
    for r in rows[1:]:
        img = np.concatenate([img, np.ones((2, width, 3)), r], axis=0)
    write_png(out, (img * 255.0 + 0.5).astype(np.uint8))


if __name__ == "__main__":
    main()
