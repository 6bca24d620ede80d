#!/usr/bin/env python3
"""Mean displayed luminance of each technique's final frame in `volux view`
(issue 30 target: switching between any two lit techniques changes it by
<= 1.5x). Starts the quick look of VOLUME, switches technique through
/api/edit, waits for each final frame (PFM, linear) and applies the
exposure the scene then holds, as the page shows it: x2^EV, the sRGB curve,
clamp. "Displayed luminance" = Rec. 709 luma of the sRGB values over the
volume's pixels (those that differ from the background colour), as
tools/viewer/exposure.c defines it.

usage: exposure_switch.py VOLUX VOLUME [--size N] [--spp N] [--no-auto]
Prints one line per technique and the pairwise max/min ratio."""
import json, re, struct, subprocess, sys, time, urllib.error, urllib.request

def srgb(v):
    if not v > 0: return 0.0
    if v >= 1: return 1.0
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055

def read_pfm(data):
    parts = data.split(b'\n', 3)
    w, h = map(int, parts[1].split()); scale = float(parts[2])
    fmt = ('<' if scale < 0 else '>') + 'f' * (w * h * 3)
    px = struct.unpack(fmt, parts[3][:w * h * 12])
    rows = [px[(h - 1 - y) * w * 3:(h - y) * w * 3] for y in range(h)]  # PFM rows bottom-up
    return w, h, [c for r in rows for c in r]

def mean_displayed(px, bg, ev, fg_only=True):
    s = 2.0 ** ev; tot = 0.0; n = 0
    for i in range(0, len(px), 3):
        p = px[i:i + 3]
        if fg_only and not any(abs(p[k] - bg[k]) > 1e-3 * (1 + abs(bg[k])) for k in range(3)):
            continue
        tot += 0.2126 * srgb(p[0] * s) + 0.7152 * srgb(p[1] * s) + 0.0722 * srgb(p[2] * s); n += 1
    return tot / max(n, 1)

def main():
    volux, volume = sys.argv[1], sys.argv[2]
    size = int(sys.argv[sys.argv.index('--size') + 1]) if '--size' in sys.argv else 128
    spp = int(sys.argv[sys.argv.index('--spp') + 1]) if '--spp' in sys.argv else 8
    techs = ['ea', 'shaded', 'single', 'ao', 'ambient', 'lightvol', 'sh', 'manylights', 'guided', 'pathtrace']
    args = [volux, 'view', volume, '--port', '0', '--threads', '2', '--width', str(size), '--height', str(size),
            '--spp', str(spp)] + (['--no-auto-exposure'] if '--no-auto' in sys.argv else [])
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    port = None
    while port is None:
        line = p.stdout.readline()
        if not line: sys.exit('volux view exited')
        m = re.search(r'http://[^:]+:(\d+)/', line)
        if m: port = int(m.group(1))
    base = f'http://127.0.0.1:{port}'
    def get(path):
        return urllib.request.urlopen(base + path, timeout=600).read()
    def edit(path, value):
        req = urllib.request.Request(base + '/api/edit', json.dumps([{'path': path, 'value': value}]).encode(),
                                     {'Content-Type': 'application/json'})
        urllib.request.urlopen(req, timeout=60).read()
    res = {}
    try:
        for t in techs:
            edit('render.technique', t)
            time.sleep(0.3)
            for attempt in range(10):  # the server waits at most 120 s per request (503 then)
                try:
                    data = get('/api/frame?wait=final&format=pfm&timeout=120000')
                    break
                except urllib.error.HTTPError as e:
                    if e.code != 503 or attempt == 9: raise
            state = json.loads(get('/api/state'))
            ev = state['resolved']['render']['exposure']
            bg = state['scene'].get('background', [0, 0, 0])
            w, h, px = read_pfm(data)
            res[t] = (ev, mean_displayed(px, bg, ev), mean_displayed(px, bg, ev, False), mean_displayed(px, bg, 0.0))
            print(f'{t:11s} EV {ev:+6.2f}  mean displayed (volume px) {res[t][1]:.3f}  (all px) {res[t][2]:.3f}'
                  f'  at EV 0: {res[t][3]:.3f}', flush=True)
    finally:
        p.terminate(); p.wait()
    lit = [t for t in techs if t != 'ea' and t in res]
    for k, name in ((1, 'volume px, applied EV'), (2, 'all px, applied EV'), (3, 'volume px, EV 0')):
        worst = max(max(res[a][k], res[b][k]) / max(min(res[a][k], res[b][k]), 1e-6) for a in lit for b in lit)
        print(f'worst pairwise ratio over lit techniques ({name}): {worst:.2f}')

main()
