#!/usr/bin/env python3
"""bench/pareto/plot.py OUTDIR [--docs DOCS_DIR]

Reads OUTDIR/pareto.jsonl (bench/pareto/run.sh) and writes, per scene and
lighting, an error-time chart OUTDIR/<scene>_<lighting>.svg (hand-written
SVG: no plotting library needed), and OUTDIR/table.md: the equal-error
speed-up S of every technique (met when S >= 4), S against the full
multiple-scattering series, the errors and the times. With --docs, copies the
charts to DOCS_DIR/images/choosing/ and the table into DOCS_DIR/CHOOSING.md
between '<!-- pareto:begin -->' and '<!-- pareto:end -->'.
"""
import json
import math
import os
import shutil
import sys

ORDER = ["ea", "shaded", "single", "ao", "ambient", "lightvol", "sh", "manylights", "guided", "pathtrace+denoise",
         "guided+denoise"]
COLORS = {"pathtrace+denoise": "#e377c2", "guided+denoise": "#393b79", "ea": "#7f7f7f", "shaded": "#bcbd22", "single": "#1f77b4", "ao": "#17becf", "ambient": "#2ca02c",
          "lightvol": "#9467bd", "sh": "#d62728", "manylights": "#ff7f0e", "guided": "#8c564b"}
TARGET = 4.0


def load(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line.startswith("{"):
                try:
                    rows.append(json.loads(line))
                except ValueError:
                    pass
    return rows


def group(rows):
    g = {}
    for r in rows:
        g.setdefault((r["name"], r["lighting"], r["width"]), []).append(r)
    return g


def fmt(v, digits=3):
    if v is None:
        return "—"
    if v < 0:
        return "n/a"
    return ("%." + str(digits) + "g") % v


def svg_chart(key, rows, path):
    """log-log error (rel_mse) against time (ms): pathtrace's series at both
    depths, each technique's points against its own model (filled) and
    against all orders (hollow)."""
    W, H, L, R, T, B = 640, 420, 70, 150, 30, 50
    series = {}
    for r in rows:
        if r["technique"] == "pathtrace" and r["metric"] == "pareto_series":
            series.setdefault(r["max_depth"], []).append((r["ms"], r["value"]))
    pts = {}
    for r in rows:
        if r["metric"] == "pareto_point":
            pts.setdefault(r["technique"], []).append((r["ms"], r["rel_mse_own"], r["rel_mse_full"], r["value"]))
    xs = [p[0] for s in series.values() for p in s] + [p[0] for s in pts.values() for p in s]
    ys = [p[1] for s in series.values() for p in s] + [v for s in pts.values() for p in s for v in p[1:3]]
    xs = [x for x in xs if x > 0]
    ys = [y for y in ys if y > 0]
    if not xs or not ys:
        return False
    x0, x1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    x1 = max(x1, x0 + 1)
    y1 = max(y1, y0 + 1)

    def X(v):
        return L + (math.log10(v) - x0) / (x1 - x0) * (W - L - R)

    def Y(v):
        return T + (y1 - math.log10(v)) / (y1 - y0) * (H - T - B)

    o = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="11">'
         % (W, H), '<rect width="100%" height="100%" fill="white"/>',
         '<text x="%d" y="18" font-size="13">%s, %s light, %d²: error against time</text>' % (L, key[0], key[1], key[2])]
    for e in range(x0, x1 + 1):
        o.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>' % (X(10 ** e), T, X(10 ** e), H - B))
        o.append('<text x="%.1f" y="%d" text-anchor="middle">%s</text>' % (X(10 ** e), H - B + 15, fmt(10 ** e)))
    for e in range(y0, y1 + 1):
        o.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>' % (L, Y(10 ** e), W - R, Y(10 ** e)))
        o.append('<text x="%d" y="%.1f" text-anchor="end">1e%d</text>' % (L - 5, Y(10 ** e) + 4, e))
    unit = next((r["unit"] for r in rows if r["metric"] == "prepare_ms"), "ms").replace("_", " ")
    o.append('<text x="%d" y="%d" text-anchor="middle">time: prepare + render (%s, log)</text>'
             % ((L + W - R) // 2, H - 12, unit))
    o.append('<text x="15" y="%d" transform="rotate(-90 15 %d)" text-anchor="middle">rel_mse (log)</text>'
             % ((T + H - B) // 2, (T + H - B) // 2))
    o.append('<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="#444"/>' % (L, T, W - L - R, H - T - B))
    ly = T + 5
    for depth in sorted(series):
        s = sorted(series[depth])
        dash = ' stroke-dasharray="5,3"' if depth == 1 else ""
        o.append('<polyline fill="none" stroke="black" stroke-width="1.5"%s points="%s"/>'
                 % (dash, " ".join("%.1f,%.1f" % (X(a), Y(b)) for a, b in s if a > 0 and b > 0)))
        for a, b in s:
            if a > 0 and b > 0:
                o.append('<circle cx="%.1f" cy="%.1f" r="2" fill="black"/>' % (X(a), Y(b)))
        o.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black" stroke-width="1.5"%s/>'
                 % (W - R + 10, ly + 4, W - R + 30, ly + 4, dash))
        o.append('<text x="%d" y="%d">pathtrace %s</text>' % (W - R + 35, ly + 8,
                                                             "1 bounce" if depth == 1 else "all orders"))
        ly += 16
    for t in ORDER:
        if t not in pts:
            continue
        c = COLORS.get(t, "black")
        p = sorted(pts[t])
        if len(p) > 1:
            o.append('<polyline fill="none" stroke="%s" points="%s"/>'
                     % (c, " ".join("%.1f,%.1f" % (X(a), Y(b)) for a, b, _, _ in p if a > 0 and b > 0)))
        for a, b, f, _ in p:
            if a > 0 and b > 0:
                o.append('<circle cx="%.1f" cy="%.1f" r="4" fill="%s"/>' % (X(a), Y(b), c))
            if a > 0 and f > 0:
                o.append('<circle cx="%.1f" cy="%.1f" r="4" fill="none" stroke="%s"/>' % (X(a), Y(f), c))
        a, b = p[0][0], p[0][1]
        if a > 0 and b > 0:
            o.append('<text x="%.1f" y="%.1f" fill="%s">%s</text>' % (X(a) + 6, Y(b) - 4, c, t))
        o.append('<circle cx="%d" cy="%d" r="4" fill="%s"/>' % (W - R + 20, ly + 4, c))
        o.append('<text x="%d" y="%d">%s</text>' % (W - R + 35, ly + 8, t))
        ly += 16
    o.append('<circle cx="%d" cy="%d" r="4" fill="none" stroke="black"/>' % (W - R + 20, ly + 8))
    o.append('<text x="%d" y="%d">hollow: vs all</text>' % (W - R + 35, ly + 12))
    o.append('<text x="%d" y="%d">orders</text>' % (W - R + 35, ly + 26))
    o.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(o) + "\n")
    return True


def table(groups):
    keys = sorted(groups, key=lambda k: (k[2], ["bonsai", "engine", "aneurism"].index(k[0])
                                         if k[0] in ("bonsai", "engine", "aneurism") else 9, k[0], k[1] != "key", k[1]))
    techs = [t for t in ORDER if any(r["technique"] == t for k in keys for r in groups[k])]

    def metric(rows, t, m):
        for r in rows:
            if r["technique"] == t and r["metric"] == m:
                return r
        return None

    lines = ["**Equal-error speed-up S** = T_pathtrace(e) / T_technique, e the technique's error against "
             "a converged pathtrace of its own model (bold: S ≥ %g; ^: the error lies below pathtrace's "
             "measured series, extrapolated as 1/spp; v: above its 1-spp point, a fractional spp)." % TARGET, "",
             "| scene | light | size | " + " | ".join("`%s`" % t for t in techs) + " |",
             "|---|---|---|" + "---|" * len(techs)]
    met = total = 0
    for k in keys:
        cells = []
        for t in techs:
            r = metric(groups[k], t, "pareto_speedup")
            if not r:
                cells.append("—")
                continue
            pt = [p for p in groups[k] if p["technique"] == t and p["metric"] == "pareto_point"
                  and p["spp"] == r["spp"]]
            where = pt[0]["where"] if pt else 0
            mark = {1: "^", -1: "v"}.get(where, "")
            s = fmt(r["value"], 2) + mark + ("" if r["spp"] == 1 else " @%d" % r["spp"])
            if t not in ("ea", "shaded"):
                total += 1
                if r["value"] >= TARGET:
                    met += 1
            cells.append("**%s**" % s if r["value"] >= TARGET else s)
        lines.append("| %s | %s | %d² | %s |" % (k[0], k[1], k[2], " | ".join(cells)))
    lines += ["", "Met (S ≥ %g, ea/shaded excepted): %d of %d." % (TARGET, met, total), ""]
    lines += ["**S against the full multiple-scattering image** (the technique's error against the "
              "all-orders reference; pathtrace's all-orders series):", "",
              "| scene | light | size | " + " | ".join("`%s`" % t for t in techs) + " |",
              "|---|---|---|" + "---|" * len(techs)]
    for k in keys:
        cells = [fmt(metric(groups[k], t, "pareto_speedup_full")["value"], 2)
                 if metric(groups[k], t, "pareto_speedup_full") else "—" for t in techs]
        lines.append("| %s | %s | %d² | %s |" % (k[0], k[1], k[2], " | ".join(cells)))
    lines += ["", "**Per frame, both prepared** (render times only: what a camera orbit sees once the "
              "technique's caches exist; pathtrace's series without its preparation):", "",
              "| scene | light | size | " + " | ".join("`%s`" % t for t in techs) + " |",
              "|---|---|---|" + "---|" * len(techs)]
    for k in keys:
        cells = []
        for t in techs:
            r = metric(groups[k], t, "pareto_speedup_frame")
            cells.append("—" if not r else ("**%s**" if r["value"] >= TARGET else "%s") % fmt(r["value"], 2))
        lines.append("| %s | %s | %d² | %s |" % (k[0], k[1], k[2], " | ".join(cells)))
    lines += ["", "**Errors and times** (rel_mse own / full; prepare ms + first image ms):", "",
              "| scene | light | size | technique | rel_mse own | rel_mse full | prepare ms | first image ms | S |",
              "|---|---|---|---|---|---|---|---|---|"]
    for k in keys:
        for t in techs:
            s = metric(groups[k], t, "pareto_speedup")
            if not s:
                continue
            p = metric(groups[k], t, "prepare_ms")
            f = metric(groups[k], t, "first_image_ms")
            lines.append("| %s | %s | %d² | `%s` | %s | %s | %.0f | %.0f | %s |" % (
                k[0], k[1], k[2], t, fmt(metric(groups[k], t, "rel_mse_own")["value"]),
                fmt(metric(groups[k], t, "rel_mse_full")["value"]), p["value"] if p else -1,
                f["value"] if f else -1, fmt(s["value"], 2)))
        pt = [r for r in groups[k] if r["technique"] == "pathtrace" and r["metric"] == "pareto_series"]
        for depth in sorted({r["max_depth"] for r in pt}):
            s = sorted((r["spp"], r["ms"], r["value"]) for r in pt if r["max_depth"] == depth)
            lines.append("| %s | %s | %d² | pathtrace d%d | %s | | | | series: %s |" % (
                k[0], k[1], k[2], depth, fmt(s[0][2]), ", ".join("%d spp %.0f ms %.2g" % x for x in s)))
    return "\n".join(lines) + "\n", keys


VOXELS = {"bonsai": 256 ** 3, "engine": 256 * 256 * 128, "aneurism": 256 ** 3}


def auto_table(groups, path, commit):
    """tools/cli/auto_table.c: per technique, the largest preparation per
    million voxels and pass per million pixels over the runs (conservative:
    a budget should hold on every scene measured) and the median error
    against the all-orders reference (pathtrace: its 1-spp point)."""
    import statistics
    per = {}
    for (name, lighting, _), rows in groups.items():
        mv = VOXELS.get(name, 0) * 1e-6
        for r in rows:
            mp = r["width"] * r["height"] * 1e-6
            t = r["technique"]
            d = per.setdefault(t, {"prep": [], "pass": [], "err": []})
            if t == "pathtrace" and r["metric"] == "pareto_series" and r["max_depth"] > 1:
                if r["spp"] == 1:
                    d["err"].append(r["value"])
                    d["one"] = d.get("one", []) + [(r["ms"], mv, mp)]
                elif "one" in d:
                    # pass time from the series: (ms(n) - ms(1)) / (n - 1)
                    d["pass"].append(max(0.0, (r["ms"] - d["one"][-1][0]) / (r["spp"] - 1)) / mp)
            elif r["metric"] == "prepare_ms" and mv:
                d["prep"].append(r["value"] / mv)
            elif r["metric"] == "first_image_ms":
                d["pass"].append(r["value"] / mp)
            elif r["metric"] == "pareto_point" and r["spp"] == 1:
                d["err"].append(r["rel_mse_full"])
    pt = per.get("pathtrace")
    if pt and "one" in pt:
        # pathtrace's preparation: ms(1 spp) minus one pass
        pas = statistics.median(pt["pass"]) if pt["pass"] else 0.0
        pt["prep"] = [max(0.0, (ms - pas * mp)) / mv for ms, mv, mp in pt["one"] if mv]
    import textwrap
    lines = ["/* tools/cli/auto_table.c — GENERATED by bench/pareto/plot.py --auto-table from",
             " * bench/pareto/run.sh:"] + [" *   " + l for l in textwrap.wrap(commit, 72)] + [
             " * The measured rows of `--technique auto`",
             " * (pareto_math.h). Costs: the largest over the scenes and lightings measured",
             " * (ms per million voxels / per million pixels and pass); error: the median",
             " * rel_mse against the all-orders pathtrace reference. */",
             '#include "pareto_math.h"', "", "const pareto_auto_row pareto_auto_table[] = {"]
    # guided is left out: an unbiased pathtrace with a sweep, its passes
    # measured as pathtrace's (identical under a key light), so its row
    # would only tie with pathtrace's and win or lose on timing noise.
    # T+denoise rows are not techniques `auto` can name.
    for t in ["pathtrace"] + [t for t in ORDER if t != "guided" and "+" not in t]:
        d = per.get(t)
        if not d or not d["err"] or not d["pass"]:
            continue
        lines.append('    {"%s", %.4g, %.4g, %.4g, %d},' % (
            t, max(d["prep"]) if d["prep"] else 0.0, max(d["pass"]), statistics.median(d["err"]),
            1 if t == "pathtrace" else 0))
    lines += ["};", "const int pareto_auto_table_rows = (int)(sizeof pareto_auto_table / sizeof pareto_auto_table[0]);", ""]
    with open(path, "w") as f:
        f.write("\n".join(lines))


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    docs = sys.argv[sys.argv.index("--docs") + 1] if "--docs" in sys.argv else None
    groups = group(load(os.path.join(out, "pareto.jsonl")))
    charts = []
    for k, rows in groups.items():
        p = os.path.join(out, "%s_%s_%d.svg" % k)
        if svg_chart(k, rows, p):
            charts.append(p)
    md, keys = table(groups)
    with open(os.path.join(out, "table.md"), "w") as f:
        f.write(md)
    print(md)
    if "--auto-table" in sys.argv:
        run = os.path.join(out, "run.txt")
        commit = open(run).readline().strip("# \n") if os.path.exists(run) else "?"
        auto_table(groups, sys.argv[sys.argv.index("--auto-table") + 1], commit)
    if docs:
        img = os.path.join(docs, "images", "choosing")
        os.makedirs(img, exist_ok=True)
        for c in charts:
            shutil.copy(c, img)
        doc = os.path.join(docs, "CHOOSING.md")
        text = open(doc).read()
        a, b = "<!-- pareto:begin -->", "<!-- pareto:end -->"
        if a in text and b in text:
            run = open(os.path.join(out, "run.txt")).read().strip() if os.path.exists(
                os.path.join(out, "run.txt")) else ""
            pics = "\n".join("![%s, %s, %d²](images/choosing/%s_%s_%d.svg)" % (k + k) for k in keys)
            body = "```\n%s\n```\n\n%s\n\n%s" % (run, md, pics)
            text = text[:text.index(a) + len(a)] + "\n" + body + "\n" + text[text.index(b):]
            with open(doc, "w") as f:
                f.write(text)


if __name__ == "__main__":
    main()
