#!/bin/bash
# Files that are not what they seem (issue 34), through the CLI:
# - outputs: a FIFO, a device, a link out of its folder are never replaced;
#   a link to a file in the same folder replaces the target and stays a link;
#   --dump-scene cannot be -o; no temporary file is left behind;
# - inputs: a FIFO named as a scene's TF file, preset or ambient table is
#   refused at once (no hang), a table outside the scene's folder rules;
# - NaN/Inf images: `compare` refuses them, `info` counts them.
# Every command runs under `timeout` so that a hang fails instead of blocking.
# Usage: hostile_files.sh VOLUX SRC_DIR
set -u
volux=${1:?usage: hostile_files.sh VOLUX SRC_DIR}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_WAIT_POLICY=passive
fail=0
bad() { echo "FAIL: $*" >&2; fail=1; }

# expect STATUS "TEXT" CMD...: exit status and a piece of stderr.
expect() {
  local want=$1 text=$2
  shift 2
  timeout 20 "$@" >"$tmp/stdout" 2>"$tmp/err"
  local got=$?
  [[ $got == "$want" ]] || bad "$* -> exit $got, want $want: $(cat "$tmp/err")"
  [[ -z $text ]] || grep -qF -- "$text" "$tmp/err" || bad "$* -> stderr lacks '$text': $(cat "$tmp/err")"
}
no_temporaries() {
  local left
  left=$(find "$tmp" -name '*.tmp*' | head -3)
  [[ -z $left ]] || bad "temporary files left behind after $1: $left"
}

small=(procedural:phantom:16 --width 16 --height 16)
mkdir -p "$tmp/out" "$tmp/elsewhere"

# ---- outputs
mkfifo "$tmp/out/fifo.png"
expect 2 "not a regular file" "$volux" render "${small[@]}" -o "$tmp/out/fifo.png"
[[ -p $tmp/out/fifo.png ]] || bad "-o FIFO: the FIFO was replaced"
expect 2 "not a regular file" "$volux" render "${small[@]}" -o "$tmp/out/x.png" --dump-scene "$tmp/out/fifo.png"
[[ -p $tmp/out/fifo.png ]] || bad "--dump-scene FIFO: the FIFO was replaced"
[[ ! -e $tmp/out/x.png ]] || bad "--dump-scene FIFO: the image was written anyway"
if [[ -c /dev/null ]]; then
  ln -s /dev/null "$tmp/out/null.pfm"
  expect 2 "" "$volux" render "${small[@]}" -o "$tmp/out/null.pfm"
  [[ -L $tmp/out/null.pfm && -c /dev/null ]] || bad "-o link to /dev/null: the link or the device was replaced"
fi
echo old >"$tmp/elsewhere/victim.pfm"
ln -s "$tmp/elsewhere/victim.pfm" "$tmp/out/away.pfm"
expect 2 "out of its folder" "$volux" render "${small[@]}" -o "$tmp/out/away.pfm"
[[ $(cat "$tmp/elsewhere/victim.pfm") == old && -L $tmp/out/away.pfm ]] || bad "-o link out of the folder was followed"
echo old >"$tmp/out/real.pfm"
ln -s real.pfm "$tmp/out/near.pfm"
expect 0 "" "$volux" render "${small[@]}" -o "$tmp/out/near.pfm"
[[ -L $tmp/out/near.pfm ]] || bad "-o link in the same folder: the link was replaced by a file"
[[ $(head -c 2 "$tmp/out/real.pfm") == PF ]] || bad "-o link in the same folder: the target was not written"
expect 2 "the same file as -o" "$volux" render "${small[@]}" -o "$tmp/out/same.png" --dump-scene "$tmp/out/same.png"
expect 2 "the same file as -o" "$volux" render "${small[@]}" -o "$tmp/out/near.pfm" --dump-scene "$tmp/out/real.pfm"
expect 0 "" "$volux" render "${small[@]}" -o "$tmp/out/ok.png" --dump-scene "$tmp/out/ok.json"
[[ -s $tmp/out/ok.png && -s $tmp/out/ok.json ]] || bad "a plain render with --dump-scene wrote nothing"
no_temporaries "the output cases"

# ---- inputs that are FIFOs: refused at once, never opened for a blocking read
mkfifo "$tmp/tf.json" "$tmp/table.vxat" "$tmp/preset.json"
cat >"$tmp/s_tf.json" <<JSON
{"volume": {"procedural": "phantom", "dims": [16, 16, 16]}, "transfer_function": "tf.json",
 "render": {"width": 16, "height": 16}}
JSON
expect 2 "not a regular file" "$volux" render "$tmp/s_tf.json" -o "$tmp/out/a.png"
cat >"$tmp/s_preset.json" <<JSON
{"volume": {"procedural": "phantom", "dims": [16, 16, 16]},
 "transfer_function": {"preset": "preset.json", "opacity": [[0, 0], [1, 1]]}, "render": {"width": 16, "height": 16}}
JSON
expect 2 "not a regular file" "$volux" render "$tmp/s_preset.json" -o "$tmp/out/a.png"
cat >"$tmp/s_table.json" <<JSON
{"volume": {"procedural": "phantom", "dims": [16, 16, 16]}, "render": {"width": 16, "height": 16,
 "technique": "ambient"}, "techniques": {"ambient": {"table_file": "table.vxat"}}}
JSON
expect 2 "not a regular file" "$volux" render "$tmp/s_table.json" -o "$tmp/out/a.png"
# the table's name is resolved against the scene's folder, like every file a scene names
pushd / >/dev/null
expect 2 "$tmp/table.vxat" "$volux" render "$tmp/s_table.json" -o "$tmp/out/a.png"
popd >/dev/null
[[ ! -e $tmp/out/a.png ]] || bad "a refused input still left an image"

# ---- NaN / Inf images
python3 - "$tmp" <<'PY'
import struct, sys
d = sys.argv[1]
def pfm(name, values):
    with open(f"{d}/{name}", "wb") as f:
        f.write(b"PF\n2 1\n-1.0\n" + struct.pack("<6f", *values))
pfm("ref.pfm", [1, 1, 1, 1, 1, 1])
pfm("one_nan.pfm", [1, float("nan"), 1, 1, 1, 1])
pfm("all_nan.pfm", [float("nan")] * 6)
pfm("inf.pfm", [1, 1, float("inf"), 1, 1, 1])
PY
expect 2 "non-finite" "$volux" compare "$tmp/one_nan.pfm" "$tmp/ref.pfm"
expect 2 "non-finite" "$volux" compare "$tmp/ref.pfm" "$tmp/inf.pfm"
expect 2 "non-finite" "$volux" compare "$tmp/all_nan.pfm" "$tmp/ref.pfm" --json
expect 0 "" "$volux" compare "$tmp/ref.pfm" "$tmp/ref.pfm"
expect 2 "6 NaN" "$volux" info "$tmp/all_nan.pfm"
expect 0 "" "$volux" info "$tmp/all_nan.pfm" --allow-nonfinite
grep -q "no finite value" "$tmp/stdout" || bad "info --allow-nonfinite on an all-NaN image: $(cat "$tmp/stdout")"
expect 0 "" "$volux" info "$tmp/one_nan.pfm" --allow-nonfinite
grep -q "nonfinite 1 NaN, 0 infinite" "$tmp/stdout" || bad "info: the NaN count is missing: $(cat "$tmp/stdout")"

# ---- more threads than the address space allows (ulimit -v): libgomp used
# to end the process with its own message; the team is now what can start.
# Not under AddressSanitizer, which reserves terabytes of address space.
if [[ -z ${ASAN_OPTIONS:-} ]] && ! ldd "$volux" 2>/dev/null | grep -q libasan; then
  (ulimit -v 300000 && exec "$volux" render procedural:phantom:24 --threads 64 --width 32 --height 32 \
     -o "$tmp/out/threads.png" --quiet) 2>"$tmp/err"
  rc=$?
  [[ $rc == 0 && -s $tmp/out/threads.png ]] || bad "--threads 64 under ulimit -v 300000: exit $rc: $(cat "$tmp/err")"
fi

exit $fail
