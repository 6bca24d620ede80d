# bench/guided/common.sh — what every bench/guided script starts with: the
# build and output folders, the two binaries, the shared data and the notes
# line naming the machine. Sourced, never run:
#
#   . "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" DEFAULT_OUT_NAME
#
# sets here, build, out (created), volux, bg; exports OMP_WAIT_POLICY and,
# when ../shared/data sits beside the checkout, VOLUX_DATA.
set -euo pipefail
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
build=${1:-$here/../../build}
out=${2:-$here/${3:-results}}
volux=$build/volux
bg=$build/bench/bench_guided
if [[ -z ${VOLUX_DATA:-} && -d $here/../../../shared/data ]]; then
  VOLUX_DATA=$(cd "$here/../../../shared/data" && pwd)
  export VOLUX_DATA
fi
mkdir -p "$out"

# needs_data SCENES: the real-volume scenes (bonsai, engine) read $VOLUX_DATA.
needs_data() {
  [[ $1 != *bonsai* && $1 != *engine* ]] || [[ -n ${VOLUX_DATA:-} ]] ||
    { echo "set VOLUX_DATA (the folder with volumes/, envmaps/)" >&2; exit 2; }
}

# note_machine [end]: one JSON line in $out/notes.jsonl — at the start the
# CPU, the load and the time, at the end the time and the load: the
# context every table needs.
note_machine() {
  local load; load=$(cut -d' ' -f1-3 /proc/loadavg)
  if [[ ${1:-} == end ]]; then
    echo "{\"end\":\"$(date -u +%FT%TZ)\",\"load\":\"$load\"}" >> "$out/notes.jsonl"
  else
    echo "{\"cpu\":\"$(lscpu | grep 'Model name' | sed 's/.*: *//')\",\"load\":\"$load\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$out/notes.jsonl"
  fi
}

# canopies: the open (one shaft) and closed procedural canopies under $out.
canopies() {
  [[ -s $out/canopy/canopy.json ]] || python3 "$here/make_canopy.py" "$out/canopy" --holes 1
  [[ -s $out/canopy_closed/canopy.json ]] || python3 "$here/make_canopy.py" "$out/canopy_closed" --holes 0
}
