#!/usr/bin/env bash
# tests/distributed/test_mpi_image.sh VOLUX SOURCE_DIR MPIRUN — the MPI
# front end (issue 15) on one machine, 1-4 ranks with --oversubscribe:
#  1. image-parallel renders of every technique are bit-identical to the
#     single-process image for 1, 2, 3 and 4 ranks;
#  2. bad input is reported once (by rank 0) with exit status 2 and no
#     output file;
#  3. a rank killed mid-render ends the whole job within 30 s, no output.
set -u
VOLUX=$1 SRC=$2 MPIRUN=$3
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
# One machine: shared memory only, no network probing.
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
T=$(mktemp -d)
export XDG_CACHE_HOME="$T/cache" # the ambient table cache, shared by the ranks
trap 'rm -rf "$T"' EXIT
fail=0
check() { if ! eval "$1"; then echo "FAIL: $2"; fail=1; else echo "ok: $2"; fi; }
mpi() { local n=$1; shift; timeout 120 "$MPIRUN" --oversubscribe -np "$n" "$VOLUX" "$@"; }

cat >"$T/scene.json" <<'JSON'
{
  "volume": {"procedural": "phantom", "dims": [24, 24, 24]},
  "transfer_function": {
    "color": [[0, 0.2, 0.3, 0.6], [140, 0.95, 0.9, 0.8], [255, 1, 1, 1]],
    "opacity": [[0, 0], [40, 0.05], [140, 0.4], [255, 0.9]],
    "albedo": 0.8
  },
  "camera": {"orbit": {"azimuth": 30, "elevation": 20}, "fov_y": 30},
  "lights": [{"type": "directional", "direction": [-0.5, -0.7, -0.5], "irradiance": 1.0}],
  "render": {"technique": "ea", "width": 72, "height": 40, "spp": 2, "threads": 1},
  "techniques": {"ambient": {"radius": 2, "table_theta": 16, "table_sigma": 16, "table_g": 3,
                             "table_paths": 64, "table_albedo": 0.8},
                 "manylights": {"vl_count": 64}}
}
JSON

# 1. bit-identical images, every technique, 1-4 ranks (72x40: 5x3 tiles,
#    so 4 ranks get uneven shares and the last row/column is partial).
techniques=$("$VOLUX" techniques | awk '/^[a-z_]+  / {print $1}')
[ -n "$techniques" ] || { echo "FAIL: no techniques listed"; exit 1; }
for t in $techniques; do
  "$VOLUX" render "$T/scene.json" --technique "$t" -o "$T/$t.pfm" --quiet || { echo "FAIL: $t single"; fail=1; continue; }
  for n in 1 2 3 4; do
    extra=""; [ "$n" = 1 ] && extra="--distribute image"
    mpi "$n" render "$T/scene.json" --technique "$t" -o "$T/$t.$n.pfm" --quiet $extra 2>"$T/err"
    check "cmp -s '$T/$t.pfm' '$T/$t.$n.pfm'" "$t: $n rank(s) bit-identical to one process"
  done
done

# 2. bad input: exit 2, one message from rank 0, no output file.
mpi 3 render "$T/missing.json" -o "$T/bad.png" 2>"$T/err"; rc=$?
check "[ $rc = 2 ]" "missing scene: exit status 2 (got $rc)"
check "[ \$(grep -c 'missing.json' '$T/err') = 1 ]" "missing scene: reported once"
check "[ ! -e '$T/bad.png' ]" "missing scene: no output file"
mpi 2 render "$T/scene.json" -o "$T/bad.png" --set 'techniques.ea.kernel="warp"' 2>"$T/err"; rc=$?
check "[ $rc = 2 ]" "bad parameter: exit status 2 (got $rc)"
check "[ \$(grep -c 'techniques.ea.kernel' '$T/err') = 1 ]" "bad parameter: reported once"
mpi 2 render "$T/scene.json" -o "$T/bad.png" --distribute sideways 2>"$T/err"; rc=$?
check "[ $rc = 2 ] && [ \$(grep -c 'distribute' '$T/err') = 1 ]" "bad --distribute value: exit 2, one message"

# 3. a rank dies: the job ends within 30 s with a failure, no output file.
"$MPIRUN" --oversubscribe -np 2 "$VOLUX" render "$T/scene.json" --technique pathtrace --spp 100000 \
  -o "$T/killed.png" --quiet 2>"$T/kill.err" &
job=$!
victim=""
for _ in $(seq 100); do
  victim=$(pgrep -f "render $T/scene.json --technique pathtrace --spp 100000" | while read -r p; do
    [ "$(ps -o comm= -p "$p")" = "$(basename "$VOLUX")" ] && echo "$p"; done | tail -1)
  [ -n "$victim" ] && [ "$(pgrep -c -f "$T/killed.png")" -ge 3 ] && break
  sleep 0.2
done
check "[ -n '$victim' ]" "found a rank to kill"
sleep 1
start=$(date +%s)
[ -n "$victim" ] && kill -9 "$victim"
ended=0
for _ in $(seq 300); do
  if ! kill -0 "$job" 2>/dev/null; then ended=1; break; fi
  sleep 0.1
done
wait "$job" 2>/dev/null; rc=$?
took=$(( $(date +%s) - start ))
check "[ $ended = 1 ]" "killed rank: job ended within 30 s (took ${took} s)"
check "[ $rc != 0 ]" "killed rank: failure exit status (got $rc)"
check "[ ! -e '$T/killed.png' ]" "killed rank: no output file"
if [ $ended = 0 ]; then pkill -9 -f "$T/killed.png"; fi
exit $fail
