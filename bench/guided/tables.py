#!/usr/bin/env python3
"""bench/guided/tables.py RESULTS_DIR [IMAGES_DIR]

Turns bench/guided/run.sh's output into the tables of docs/techniques/guided.md
(Markdown on stdout), SVG plots (MSE vs spp and vs CPU time per strategy, the
animated sequence's per-frame error) and PNG strips of the images
(reference | strategies) into IMAGES_DIR (default: RESULTS_DIR).
Standard library only (zlib, struct): no numpy on the development machine.
"""
import json
import math
import os
import struct
import sys
import zlib

DIMS = {"bonsai": (256, 256, 256), "engine": (256, 256, 128)}


def rows(path):
    out = []
    if not os.path.exists(path):
        return out
    for line in open(path):
        line = line.strip()
        if line.startswith("{"):
            out.append(json.loads(line))
    return out


def scene_of(r):
    return os.path.splitext(os.path.basename(r["scene"]))[0]


# ---------------------------------------------------------------- images

def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read(w * h * 12)
    fmt = ("<" if scale < 0 else ">") + "%df" % (w * h * 3)
    v = struct.unpack(fmt, data)
    rows_ = [v[(h - 1 - y) * w * 3:(h - y) * w * 3] for y in range(h)]  # PFM is bottom-up
    return w, h, rows_


def srgb(x):
    x = max(0.0, min(1.0, x))
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


def write_png(path, w, h, pix):
    raw = b"".join(b"\x00" + bytes(pix[y]) for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def strip(paths, out, exposure=0.0, gap=4):
    imgs = [read_pfm(p) for p in paths if os.path.exists(p)]
    if not imgs:
        return False
    w, h = imgs[0][0], imgs[0][1]
    W = len(imgs) * w + (len(imgs) - 1) * gap
    k = 2.0 ** exposure
    pix = [bytearray([255] * (3 * W)) for _ in range(h)]
    for i, (_, _, rr) in enumerate(imgs):
        x0 = i * (w + gap)
        for y in range(h):
            row = rr[y]
            for x in range(w):
                for c in range(3):
                    pix[y][3 * (x0 + x) + c] = int(round(255 * srgb(k * row[3 * x + c])))
    write_png(out, W, h, pix)
    return True


# ---------------------------------------------------------------- SVG plots

COLORS = ["#d62728", "#e6a700", "#2ca02c", "#17becf", "#c71585", "#1f77b4", "#7f7f7f"]


def svg_plot(path, title, series, xlabel, ylabel, logx=True, logy=True):
    """series: [(label, [(x, y), ...])]; log-log axes."""
    W, H, L, R, T, B = 520, 340, 70, 150, 30, 45
    pts = [(x, y) for _, s in series for x, y in s if x > 0 and y > 0]
    if not pts:
        return
    fx = (lambda v: math.log10(v)) if logx else (lambda v: v)
    fy = (lambda v: math.log10(v)) if logy else (lambda v: v)
    x0, x1 = min(fx(x) for x, _ in pts), max(fx(x) for x, _ in pts)
    y0, y1 = min(fy(y) for _, y in pts), max(fy(y) for _, y in pts)
    if logy:
        y0, y1 = math.floor(y0), math.ceil(y1)
    if x1 == x0:
        x1 = x0 + 1
    if y1 == y0:
        y1 = y0 + 1
    X = lambda v: L + (fx(v) - x0) / (x1 - x0) * (W - L - R)
    Y = lambda v: H - B - (fy(v) - y0) / (y1 - y0) * (H - T - B)
    o = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="11">' % (W, H),
         '<rect width="100%" height="100%" fill="white"/>',
         '<text x="%d" y="18" font-size="13">%s</text>' % (L, title),
         '<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="#444"/>' % (L, T, W - L - R, H - T - B)]
    if logy:
        for e in range(int(y0), int(y1) + 1):
            yy = H - B - (e - y0) / (y1 - y0) * (H - T - B)
            o.append('<line x1="%d" x2="%d" y1="%.1f" y2="%.1f" stroke="#ddd"/>' % (L, W - R, yy, yy))
            o.append('<text x="%d" y="%.1f" text-anchor="end">1e%d</text>' % (L - 4, yy + 4, e))
    xt = sorted({x for x, _ in pts})
    if logx and len(xt) > 8:
        xt = [10 ** e for e in range(int(math.floor(x0)), int(math.ceil(x1)) + 1)]
    for x in xt:
        if x0 - 1e-9 <= fx(x) <= x1 + 1e-9:
            o.append('<text x="%.1f" y="%d" text-anchor="middle">%g</text>' % (X(x), H - B + 14, x))
    o.append('<text x="%d" y="%d" text-anchor="middle">%s</text>' % ((L + W - R) // 2, H - 8, xlabel))
    o.append('<text x="14" y="%d" transform="rotate(-90 14 %d)" text-anchor="middle">%s</text>' % ((T + H - B) // 2, (T + H - B) // 2, ylabel))
    for i, (label, s) in enumerate(series):
        s = [(x, y) for x, y in s if x > 0 and y > 0]
        if not s:
            continue
        c = COLORS[i % len(COLORS)]
        o.append('<polyline fill="none" stroke="%s" stroke-width="1.8" points="%s"/>' % (c, " ".join("%.1f,%.1f" % (X(x), Y(y)) for x, y in s)))
        for x, y in s:
            o.append('<circle cx="%.1f" cy="%.1f" r="2.2" fill="%s"/>' % (X(x), Y(y), c))
        o.append('<text x="%d" y="%d" fill="%s">%s</text>' % (W - R + 8, T + 14 + 15 * i, c, label))
    o.append("</svg>")
    open(path, "w").write("\n".join(o))


# ---------------------------------------------------------------- tables

def metric(rs, scene, label, name):
    for r in rs:
        if scene_of(r) == scene and r.get("label") == label and r["metric"] == name:
            return r["value"]
    return None


def table1(res):
    rs = rows(os.path.join(res, "table1.jsonl"))
    if not rs:
        return
    print("### Table 1 — visibility sweeps vs brute force (CPU ms, all threads; median of 3)\n")
    print("| volume | grid positions | grid MB | sweep 1 ray/voxel | 1/2 | 1/4 | 1/8 | brute force | brute / sweep |")
    print("|---|---|---|---|---|---|---|---|---|")
    for sc in ("bonsai", "engine"):
        for cell in (2, 4, 8, 16):
            t = [metric(rs, sc, "sweep cell %d rays %d" % (cell, k), "visibility_cpu_ms") for k in (1, 2, 4, 8)]
            if t[0] is None:
                continue
            bf = metric(rs, sc, "bruteforce cell %d" % cell, "visibility_cpu_ms")
            mem = metric(rs, sc, "sweep cell %d rays 1" % cell, "memory_bytes")
            g = [max(1, -(-(d - 1) // cell)) for d in DIMS[sc]]
            print("| %s | %d×%d×%d | %.1f | %s | %s | %s | %s | %s | %s |" % (
                sc, g[0], g[1], g[2], (mem or 0) / 2 ** 20, *["%.0f" % x if x else "—" for x in t],
                "%.0f" % bf if bf else "—", "%.1f×" % (bf / t[0]) if bf else "—"))
    for sc in ("bonsai", "engine"):
        sc_t = metric(rs, sc, "sweep default scalar", "visibility_cpu_ms")
        simd = metric(rs, sc, "sweep cell 4 rays 1", "visibility_cpu_ms")
        if sc_t and simd:
            print("\n%s, default grid: portable row loop %.0f ms, AVX-512 %.0f ms (%.1f×)." % (sc, sc_t, simd, sc_t / simd), end="")
    print("\n")


def table2(res):
    rs = rows(os.path.join(res, "table2.jsonl"))
    if not rs:
        return
    print("### Table 2 — sweep-space filtering vs angular oversampling (default grid)\n")
    print("| volume | visibility | CPU ms | × unfiltered | MSE at 64 spp | × unfiltered |")
    print("|---|---|---|---|---|---|")
    for sc in ("bonsai", "engine"):
        base_t = metric(rs, sc, "unfiltered", "visibility_cpu_ms")
        base_e = None
        for r in rs:
            if scene_of(r) == sc and r.get("label") == "unfiltered" and r["metric"] == "convergence.mse" and r["spp"] == 64:
                base_e = r["mse"]
        for label in ("unfiltered", "filtered", "filtered_beta0", "oversample4", "oversample16", "bruteforce"):
            t = metric(rs, sc, label, "visibility_cpu_ms")
            e = None
            for r in rs:
                if scene_of(r) == sc and r.get("label") == label and r["metric"] == "convergence.mse" and r["spp"] == 64:
                    e = r["mse"]
            if t is None:
                continue
            print("| %s | %s | %.0f | %.2f | %.3g | %s |" % (sc, label, t, t / base_t if base_t else 0, e or 0,
                                                           "%.2f" % (e / base_e) if e and base_e else "—"))
    print()


def series(rs, sc, label, x="spp"):
    return [(r[x], r["mse"]) for r in rs if scene_of(r) == sc and r.get("label") == label and r["metric"] == "convergence.mse"]


def at_cpu(s, budget):
    """MSE at CPU time `budget` by log-log interpolation of (cpu_ms, mse)."""
    s = sorted(s)
    for (x0, y0), (x1, y1) in zip(s, s[1:]):
        if x0 <= budget <= x1:
            t = (math.log(budget) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(y0) + t * (math.log(y1) - math.log(y0)))
    if s and budget > s[-1][0]:  # extrapolate with MSE ∝ 1/time
        return s[-1][1] * s[-1][0] / budget
    return None


def convergence_tables(res, name, labels, img, title):
    rs = rows(os.path.join(res, name + ".jsonl"))
    if not rs:
        return
    print("### %s\n" % title)
    for sc in ("bonsai", "engine"):
        spps = sorted({r["spp"] for r in rs if scene_of(r) == sc and r["metric"] == "convergence.mse"})
        if not spps:
            continue
        print("**%s** — MSE by samples per pixel; render CPU time at the last column's spp; equal-CPU-time MSE at the "
              "budget of two_step's (or the first guided run's) last spp:\n" % sc)
        present = [l for l in labels if series(rs, sc, l)]
        ref_label = "two_step" if "two_step" in present else present[-1]
        budget = max(x for x, _ in series(rs, sc, ref_label, "cpu_ms"))
        print("| strategy | " + " | ".join("%d spp" % s for s in spps) + " | CPU ms | prepare CPU ms | MSE at equal CPU time |")
        print("|---|" + "---|" * (len(spps) + 3))
        for l in present:
            by = dict(series(rs, sc, l))
            cpu = max(x for x, _ in series(rs, sc, l, "cpu_ms"))
            prep = metric(rs, sc, l, "prepare_cpu_ms")
            eq = at_cpu(series(rs, sc, l, "cpu_ms"), budget)
            print("| %s | " % l + " | ".join("%.3g" % by[s] if s in by else "—" for s in spps) +
                  " | %.0f | %.0f | %s |" % (cpu, prep or 0, "%.3g" % eq if eq else "—"))
        print()
        svg_plot(os.path.join(img, "guided_%s_%s_spp.svg" % (name, sc)), "%s: MSE vs samples per pixel" % sc,
                 [(l, series(rs, sc, l)) for l in present], "samples per pixel", "MSE")
        svg_plot(os.path.join(img, "guided_%s_%s_time.svg" % (name, sc)), "%s: MSE vs render CPU time" % sc,
                 [(l, series(rs, sc, l, "cpu_ms")) for l in present], "render CPU ms (all threads)", "MSE")


def lazy(res, img):
    rs = rows(os.path.join(res, "lazy.jsonl"))
    if not rs:
        return
    print("### Animated sequence — lazy visibility updates (48 steps of the 128³ cloud, 8 spp per frame)\n")
    print("| policy | update CPU ms per step (median) | full update CPU ms | per step / full | mean MSE | first 12 frames | last 12 frames |")
    print("|---|---|---|---|---|---|---|")
    curves = []
    for label in ("off", "round_robin", "environment", "static", "environment sampling"):
        st = [r for r in rs if r.get("label") == label and r["metric"] == "lazy.step"]
        if not st:
            continue
        upd = metric(rs, "cloud_sequence", label, "update_cpu_ms.time_step")
        full = metric(rs, "cloud_sequence", label, "update_cpu_ms.full")
        mse = [r["mse"] for r in st]
        curves.append((label, [(r["step"] + 1, r["mse"]) for r in st]))
        print("| %s | %.1f | %.0f | %s | %.3g | %.3g | %.3g |" % (
            label, upd or 0, full or 0, "%.3f" % (upd / full) if upd and full else "—", sum(mse) / len(mse),
            sum(mse[:12]) / 12, sum(mse[-12:]) / 12))
    print()
    svg_plot(os.path.join(img, "guided_lazy_frames.svg"), "animated cloud: MSE per frame (8 spp)", curves,
             "frame", "MSE", logx=False)


def main():
    res = sys.argv[1]
    img = sys.argv[2] if len(sys.argv) > 2 else res
    os.makedirs(img, exist_ok=True)
    for r in rows(os.path.join(res, "notes.jsonl")):
        print("<!-- %s (load %s, %s) -->" % (r["note"], r["load"], r["date"]))
    table1(res)
    table2(res)
    convergence_tables(res, "strategies", ["pathtrace", "uniform", "environment", "visibility", "product", "two_step"],
                       img, "Strategies (Figs. 9–13) — single scattering")
    convergence_tables(res, "multiple", ["pathtrace", "guided depth 1", "guided depth 0"], img,
                       "Guided multiple scattering — max_depth 8")
    lazy(res, img)
    for sc in ("bonsai", "engine"):
        strip([os.path.join(res, "%s_ref.pfm" % sc)] + [os.path.join(res, "%s_%s_16.pfm" % (sc, s))
                                                         for s in ("uniform", "environment", "two_step")],
              os.path.join(img, "guided_%s_strategies.png" % sc))


if __name__ == "__main__":
    main()
