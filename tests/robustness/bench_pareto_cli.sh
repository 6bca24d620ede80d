#!/bin/bash
# `volux bench --pareto` (issue 26's error–time plane) as a user calls it:
# names checked before any work, and the T+denoise rows of issue 33 — the
# denoised frames must be nearer the reference than the raw series at the
# same sample count (the denoiser's whole point; its time is counted).
# Usage: bench_pareto_cli.sh VOLUX SRC_DIR
set -u
volux=${1:?usage: bench_pareto_cli.sh VOLUX SRC_DIR}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_WAIT_POLICY=passive
fail=0
bad() { echo "FAIL: $*" >&2; fail=1; }

cat >"$tmp/s.json" <<'JSON'
{"volume": {"procedural": "phantom", "dims": [24, 24, 24]},
 "transfer_function": {"color": [[0, 1, 1, 1], [255, 1, 1, 1]],
                       "opacity": [[0, 0], [60, 0], [120, 0.6], [255, 0.9]], "albedo": 0.9},
 "lights": [{"type": "directional", "direction": [-0.4, -1, -0.3], "irradiance": 3},
            {"type": "environment", "radiance": 0.3}],
 "camera": {"orbit": {"azimuth": 30, "elevation": 20, "distance": 2.2}, "fov_y": 30},
 "render": {"technique": "pathtrace", "width": 24, "height": 24, "max_depth": 8, "threads": 2}}
JSON

for name in pathtrace sh+blur nosuch+denoise; do
  "$volux" bench "$tmp/s.json" --pareto --techniques "$name" >"$tmp/out" 2>"$tmp/err"
  rc=$?
  [[ $rc == 2 ]] || bad "--techniques $name -> exit $rc, want 2"
  grep -qF "'$name'" "$tmp/err" || bad "--techniques $name: the message does not name it: $(cat "$tmp/err")"
done

"$volux" bench "$tmp/s.json" --pareto --json --techniques pathtrace+denoise --ref-spp 256 --series-spp 16 \
  --tech-spp 16 >"$tmp/p.jsonl" 2>"$tmp/err" || bad "pareto pathtrace+denoise failed: $(cat "$tmp/err")"
python3 - "$tmp/p.jsonl" <<'PY' || fail=1
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
raw = {r["spp"]: r["value"] for r in rows if r["technique"] == "pathtrace" and r["metric"] == "pareto_series"}
den = {r["spp"]: r["rel_mse_own"] for r in rows
       if r["technique"] == "pathtrace+denoise" and r["metric"] == "pareto_point"}
heads = {r["metric"] for r in rows if r["technique"] == "pathtrace+denoise"}
need = {"prepare_ms", "first_image_ms", "pareto_point", "pareto_speedup", "rel_mse_own"}
if not need <= heads:
    sys.exit("FAIL: pathtrace+denoise rows lack %s" % sorted(need - heads))
for spp in (1, 4, 16):
    if spp not in raw or spp not in den:
        sys.exit("FAIL: no %d-spp point (raw %s, denoised %s)" % (spp, sorted(raw), sorted(den)))
    if not den[spp] < raw[spp]:
        sys.exit("FAIL: denoised %d spp rel_mse %.4g is not below raw %.4g" % (spp, den[spp], raw[spp]))
print("denoised / raw rel_mse:", {s: round(den[s] / raw[s], 3) for s in (1, 4, 16)})
PY
exit $fail
