#!/usr/bin/python3
"""Image conversions for bench/vtk_compare.sh (run with Debian's /usr/bin/python3,
which has numpy; PNG reading uses the peers' VTK reader).

The peers write PNGs holding *linear* colour composited over black (no gamma),
while `volux render x.png` tone-maps with the sRGB curve. To compare like with
like, both sides are brought to linear floats:

  img_convert.py png2pfm PEER.png OUT.pfm     8-bit linear PNG -> linear PFM (v/255)
  img_convert.py pfm2png VOLUX.pfm OUT.png    linear PFM -> 8-bit linear PNG (peers' convention)
"""
import os
import sys

import numpy as np

PEERS = os.environ.get("PEERS", os.path.join(os.environ.get("VOLUX_DATA", os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")), "..", "peers"))
sys.path.insert(0, PEERS)


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise SystemExit("%s: not an RGB PFM" % path)
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(w * h * 12), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return data[::-1].astype(np.float64)  # PFM rows are bottom-up


def write_pfm(path, a):
    h, w, _ = a.shape
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(a[::-1], dtype="<f4").tobytes())


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("png2pfm", "pfm2png"):
        raise SystemExit(__doc__)
    mode, src, dst = sys.argv[1:]
    if mode == "png2pfm":
        import compare_png
        write_pfm(dst, compare_png.read_png(src) / 255.0)
    else:
        import peers_common as pc
        a = read_pfm(src)
        b = np.clip(np.rint(a * 255.0), 0, 255).astype(np.uint8)
        pc.write_png(dst, a.shape[1], a.shape[0], b.tobytes())


if __name__ == "__main__":
    main()
