#!/usr/bin/env bash
# bench/pareto/run.sh — issue 26's error-time plane for every technique on
# bonsai, engine and aneurism (bench/ambient/*.json) under a key light (the
# scene's own) and an HDR map (only the Venice sunset, intensity 1), with
# `volux bench --pareto` (tools/cli/bench_pareto.c), then the charts and
# the speed-up table of docs/CHOOSING.md (plot.py).
#
#   bench/pareto/run.sh [VOLUX] [OUTDIR]
#
# Parameters (environment): SIZE=128 REF_SPP=1024 SERIES_SPP=64 TECH_SPP=16
# SCENES="bonsai engine aneurism" LIGHTS="key env" TECHNIQUES=(bench's
# default: ea shaded single ao ambient lightvol sh manylights guided
# pathtrace+denoise)
# TIMEOUT=3600 (seconds per scene and lighting) MAX_DEPTH=64.
# References are kept in OUTDIR/refs and reused (delete them after changing
# SIZE/REF_SPP or the scenes). Writes OUTDIR/pareto.jsonl (bench --json
# lines plus "lighting"), OUTDIR/<scene>_<lighting>.svg, OUTDIR/table.md;
# DOCS=1 also copies the charts to docs/images/choosing/, the table into
# docs/CHOOSING.md (between its markers) and regenerates the measured table
# of `--technique auto` (tools/cli/auto_table.c; rebuild afterwards).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-$here/out}
size=${SIZE:-128}
ref_spp=${REF_SPP:-1024}
series_spp=${SERIES_SPP:-64}
tech_spp=${TECH_SPP:-16}
max_depth=${MAX_DEPTH:-64}
scenes=${SCENES:-"bonsai engine aneurism"}
lightings=${LIGHTS:-"key env"}
limit=${TIMEOUT:-3600}
envmap=${ENVMAP:-/work/shared/data/envmaps/venice_sunset_1k.hdr}
export VOLUX_DATA=${VOLUX_DATA:-/work/shared/data}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
jsonl="$out/pareto.jsonl"
: > "$jsonl"
tech_opt=()
[ -n "${TECHNIQUES:-}" ] && tech_opt=(--techniques "$TECHNIQUES")
env_light="{\"type\": \"environment\", \"file\": \"$envmap\", \"intensity\": 1.0, \"visible\": false}"
{ echo "# $(date -u +%FT%TZ) $(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo '?')" \
    "size=$size ref_spp=$ref_spp series_spp=$series_spp tech_spp=$tech_spp"; uptime; nproc; } > "$out/run.txt"

for scene in $scenes; do
  json="$here/../ambient/$scene.json"
  key=$(python3 -c "import json,sys; print(json.dumps(json.load(open(sys.argv[1]))['lights']))" "$json")
  for lighting in $lightings; do
    case $lighting in
      key) lights=$key ;;
      env) lights="[$env_light]" ;;
      *) echo "run.sh: unknown lighting $lighting" >&2; exit 2 ;;
    esac
    refs="$out/refs/${scene}_$lighting"
    mkdir -p "$refs"
    echo "== $scene $lighting ($(uptime | sed 's/.*load/load/'))" >&2
    timeout "$limit" "$volux" bench "$json" --pareto --json --width "$size" --height "$size" \
      --set "lights=$lights" --set "render.max_depth=$max_depth" --ref-spp "$ref_spp" \
      --series-spp "$series_spp" --tech-spp "$tech_spp" --reference-dir "$refs" "${tech_opt[@]}" |
      sed -u "s/^{/{\"name\":\"$scene\",\"lighting\":\"$lighting\",/" | tee -a "$jsonl" ||
      echo "run.sh: $scene $lighting did not finish (timeout $limit s or failure)" | tee -a "$out/run.txt" >&2
  done
done
uptime >> "$out/run.txt"
python3 "$here/plot.py" "$out" ${DOCS:+--docs "$here/../../docs" --auto-table "$here/../../tools/cli/auto_table.c"}
