#!/usr/bin/env python3
"""bench/guided/lazy.py OUT_DIR/lazy.jsonl — per-policy summary of run.sh's
lazy phase: update CPU per step (median, mean), against the full update,
and the per-frame MSE relative to policy "off" (every direction from the
current step) at the same step.
"""
import json,statistics as S,sys
rows={};extra={}
for l in open(sys.argv[1]):
    d=json.loads(l)
    if d['metric']=='lazy.step': rows.setdefault(d['label'],[]).append(d)
    else: extra.setdefault(d['label'],{})[d['metric']]=d['value']
off={x['step']:x['mse'] for x in rows.get('off',[])}
for k,v in rows.items():
    e=extra.get(k,{})
    ratios=[x['mse']/off[x['step']] for x in v if x['step'] in off]
    print(f"{k:22s} steps {len(v)} upd/step cpu med {S.median([x['update_cpu_ms'] for x in v[1:]]):8.1f} full {e.get('update_cpu_ms.full',float('nan')):8.1f} ratio {S.median([x['update_cpu_ms'] for x in v[1:]])/e.get('update_cpu_ms.full',float('nan')):.3f} mean upd {S.mean([x['update_cpu_ms'] for x in v[1:]]):8.1f} MSE mean {S.mean([x['mse'] for x in v]):.4f} vs off: mean ratio {S.mean(ratios):.3f} median {S.median(ratios):.3f} render cpu {S.median([x['render_cpu_ms'] for x in v]):.1f}")
