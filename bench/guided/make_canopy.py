#!/usr/bin/env python3
"""bench/guided/make_canopy.py OUT_DIR [--size N] [--holes K] — writes the `canopy` scene of
docs/techniques/guided.md ("A scene where visibility matters") into OUT_DIR:
canopy.nhdr + canopy.raw (uint8, N^3), sun_sky.pfm (equirectangular, +Y up)
and canopy.json. Procedural and deterministic: nothing from ../shared.

The kind of scene the paper's joint sampling is made for (§7: "shadowed
regions may appear noisy" under environment importance sampling): a fog
box under a dense roof with two dense side walls and a dense floor, open at
the front (towards the camera) and the back, with three round holes in the
roof. The environment is a sky with a small sun high above (~93 % of the
map's power in ~0.01 sr). Almost every scattering point in the fog sees
the sky only through the front/back openings and the sun only where a hole
lets a shaft through: environment sampling sends most shadow rays at the
sun and into the roof; (V + eps) * L sends them where light gets in.

File values: 0 air, 100 fog, 255 walls (see the TF in canopy.json).
"""
import math
import os
import struct
import sys


def volume(n, n_holes):
    holes = [(0.30, 0.35), (0.62, 0.55), (0.45, 0.75)][:n_holes]  # roof holes, (x, z) centres
    hole_r = 0.06
    out = bytearray(n * n * n)
    i = 0
    for k in range(n):  # z slowest (file order: x fastest, then y, then z)
        z = (k + 0.5) / n
        for j in range(n):
            y = (j + 0.5) / n
            for ii in range(n):
                x = (ii + 0.5) / n
                v = 0
                inside_xz = 0.05 <= x <= 0.95 and 0.05 <= z <= 0.95
                if inside_xz and 0.78 <= y <= 0.88:  # roof with holes
                    v = 255
                    for hx, hz in holes:
                        if (x - hx) ** 2 + (z - hz) ** 2 < hole_r * hole_r:
                            v = 0
                elif inside_xz and 0.02 <= y < 0.06:  # floor
                    v = 255
                elif 0.05 <= z <= 0.95 and 0.06 <= y < 0.78 and (0.05 <= x < 0.13 or 0.87 < x <= 0.95):  # side walls
                    v = 255
                elif 0.13 <= x <= 0.87 and 0.06 <= y < 0.78 and 0.05 <= z < 0.13:  # back wall
                    v = 255
                elif 0.13 <= x <= 0.87 and 0.06 <= y < 0.78 and 0.13 <= z <= 0.92:  # fog
                    v = 100
                out[i] = v
                i += 1
    return out


def sun_sky(w, h):
    """Sky 1.0 (bluish) above the horizon, ground 0.15 below, a sun of 2.5
    degrees radius at elevation 62 degrees, azimuth 10 degrees from -z (behind the box as the camera sees it). DESIGN
    §2: u = 0.5 + atan2(d.x, -d.z)/(2 pi), v = acos(d.y)/pi, row 0 = top."""
    el, az = math.radians(62.0), math.radians(10.0)
    sun = (math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az))
    cos_r = math.cos(math.radians(2.5))
    rows = []
    for r in range(h):
        v = (r + 0.5) / h
        theta = v * math.pi
        row = []
        for c in range(w):
            u = (c + 0.5) / w
            phi = (u - 0.5) * 2.0 * math.pi
            d = (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))
            if d[1] >= 0.0:
                rgb = (0.6 + 0.2 * d[1], 0.75 + 0.15 * d[1], 1.0)
            else:
                rgb = (0.15, 0.13, 0.1)
            if d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] > cos_r:
                rgb = (9000.0, 8500.0, 8000.0)
            row.append(rgb)
        rows.append(row)
    return rows


def write_pfm(path, rows):
    h, w = len(rows), len(rows[0])
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for row in reversed(rows):  # PFM stores bottom-to-top
            f.write(b"".join(struct.pack("<3f", *p) for p in row))


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: make_canopy.py OUT_DIR [--size N] [--holes K]")
    out = sys.argv[1]
    n = int(sys.argv[sys.argv.index("--size") + 1]) if "--size" in sys.argv else 96
    n_holes = int(sys.argv[sys.argv.index("--holes") + 1]) if "--holes" in sys.argv else 3
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "canopy.raw"), "wb") as f:
        f.write(volume(n, n_holes))
    with open(os.path.join(out, "canopy.nhdr"), "w") as f:
        f.write("NRRD0004\ntype: uint8\ndimension: 3\nsizes: %d %d %d\nspacings: 1 1 1\n"
                "encoding: raw\ndata file: canopy.raw\n" % (n, n, n))
    write_pfm(os.path.join(out, "sun_sky.pfm"), sun_sky(256, 128))
    s = 96.0 / n  # keep optical depths independent of the size
    with open(os.path.join(out, "canopy.json"), "w") as f:
        f.write("""{
  "comment": "guided: fog under a dense roof with holes, lit by a sky with a small sun (bench/guided/make_canopy.py)",
  "volume": {"file": "canopy.nhdr"},
  "transfer_function": {"color": [[0, 1, 1, 1], [255, 1, 1, 1]],
                        "extinction": [[0, 0], [100, %.4g], [104, %.4g], [110, %.4g], [255, %.4g]],
                        "albedo": 0.9, "anisotropy": 0.2},
  "camera": {"orbit": {"azimuth": 10, "elevation": 3, "distance": 3.9}, "fov_y": 10},
  "lights": [{"type": "environment", "file": "sun_sky.pfm", "intensity": 1.0}],
  "render": {"technique": "guided", "width": 64, "height": 64, "spp": 64, "max_depth": 1},
  "techniques": {"guided": {"strategy": "two_step"}}
}
""" % (0.04 * s, 0.04 * s, 1.0 * s, 1.0 * s))


if __name__ == "__main__":
    main()
