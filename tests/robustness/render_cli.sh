#!/bin/bash
# `volux render` as a new user meets it (issue 18): a volume instead of a
# scene, --dump-scene, outputs checked before any work, Ctrl-C / SIGTERM
# keeping the image so far, the small messages.
# Usage: render_cli.sh VOLUX SRC_DIR
set -u
volux=${1:?usage: render_cli.sh VOLUX SRC_DIR}
src=${2:?usage: render_cli.sh VOLUX SRC_DIR}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_WAIT_POLICY=passive
fail=0
bad() { echo "FAIL: $*" >&2; fail=1; }

# expect STATUS "TEXT" CMD...: runs CMD, checks its exit status and that
# stderr contains TEXT.
expect() {
  local want=$1 text=$2
  shift 2
  "$@" >"$tmp/out" 2>"$tmp/err"
  local got=$?
  [[ $got == "$want" ]] || bad "$* -> exit $got, want $want: $(cat "$tmp/err")"
  [[ -z $text ]] || grep -qF -- "$text" "$tmp/err" || bad "$* -> stderr lacks '$text': $(cat "$tmp/err")"
}

small=(--width 32 --height 32)

# ---- quick look: a volume, its dumped scene renders the same image
expect 0 "" "$volux" render procedural:phantom:24 -o "$tmp/q.pfm" "${small[@]}" --dump-scene "$tmp/q.json"
[[ -s $tmp/q.pfm && -s $tmp/q.json ]] || bad "quick look wrote no image or no scene"
grep -q '"technique": "shaded"' "$tmp/q.json" || bad "the default scene is not shaded"
expect 0 "" "$volux" render "$tmp/q.json" -o "$tmp/q2.pfm" "${small[@]}"
"$volux" compare "$tmp/q2.pfm" "$tmp/q.pfm" --json | grep -q '"max_abs":0[,}]' ||
  bad "the dumped scene does not render the quick-look image: $("$volux" compare "$tmp/q2.pfm" "$tmp/q.pfm" --json)"
# A scene without a TF gets the default and says so.
printf '{"volume": {"procedural": "sphere", "dims": [16, 16, 16]}}\n' >"$tmp/notf.json"
expect 0 "note: " "$volux" render "$tmp/notf.json" -o "$tmp/notf.png" "${small[@]}"
grep -qF "no transfer_function" "$tmp/err" || bad "no note about the default TF: $(cat "$tmp/err")"
expect 0 "" "$volux" render "$tmp/notf.json" -o "$tmp/notf.png" "${small[@]}" --quiet
[[ ! -s $tmp/err ]] || bad "--quiet still printed: $(cat "$tmp/err")"
printf 'not a volume\n' >"$tmp/what.txt"
expect 2 "neither a scene" "$volux" render "$tmp/what.txt" -o "$tmp/w.png"

# ---- outputs are checked before any work (a huge spp would take minutes)
heavy=(procedural:cloud:64 --technique pathtrace --spp 100000 --width 256 --height 256)
start=$SECONDS
expect 2 "/nonexistent/x.exr" "$volux" render "${heavy[@]}" -o /nonexistent/x.exr
expect 2 "cannot write this extension" "$volux" render "${heavy[@]}" -o "$tmp/x.jpg"
mkdir "$tmp/d.png"
expect 2 "is a folder" "$volux" render "${heavy[@]}" -o "$tmp/d.png"
expect 2 "--dump-scene" "$volux" render "${heavy[@]}" -o "$tmp/x.png" --dump-scene /nonexistent/s.json
((SECONDS - start < 20)) || bad "bad outputs were found only after rendering ($((SECONDS - start)) s)"
[[ ! -e $tmp/x.png ]] || bad "a failed run left $tmp/x.png"

# ---- SIGINT / SIGTERM: the image so far, with its spp, exit 128 + signal
# interrupt SIGNAL OUT: starts a long progressive render, signals it once
# the first samples can be there, prints the exit status.
interrupt() {
  local sig=$1 out=$2 wait_s
  for wait_s in 1 2 4 8; do
    rm -f "$out"
    "$volux" render procedural:sphere:24 --technique pathtrace --spp 1000000 --width 48 --height 48 \
      -o "$out" 2>"$tmp/int_err" &
    local pid=$!
    sleep "$wait_s"
    kill -s "$sig" "$pid"
    wait "$pid"
    local rc=$?
    # Before the first complete sample nothing is written; try longer.
    [[ -e $out ]] || grep -q "before the first sample" "$tmp/int_err" || { echo "$rc"; return; }
    [[ -e $out ]] && { echo "$rc"; return; }
  done
  echo "never-started"
}
rc=$(interrupt INT "$tmp/int.png")
[[ $rc == 130 ]] || bad "SIGINT: exit $rc, want 130: $(cat "$tmp/int_err")"
grep -q "interrupted at [0-9]* of 1000000 spp" "$tmp/int_err" || bad "SIGINT message: $(cat "$tmp/int_err")"
if [[ -e $tmp/int.png ]]; then
  "$volux" info "$tmp/int.png" >"$tmp/meta" || bad "volux info cannot read the interrupted image"
  grep -q "volux.interrupted = true" "$tmp/meta" || bad "no volux.interrupted in the PNG: $(cat "$tmp/meta")"
  spp=$(sed -n 's/.*volux\.spp = //p' "$tmp/meta")
  [[ $spp =~ ^[0-9]+$ ]] && ((spp >= 1)) || bad "PNG metadata spp '$spp'"
  grep -q "interrupted at $spp of" "$tmp/int_err" || bad "message and metadata disagree on spp ($spp)"
else
  bad "SIGINT wrote no image: $(cat "$tmp/int_err")"
fi
rc=$(interrupt TERM "$tmp/term.exr")
[[ $rc == 143 ]] || bad "SIGTERM: exit $rc, want 143"
[[ -e $tmp/term.exr ]] && { "$volux" info "$tmp/term.exr" | grep -q "volux.interrupted = true" || bad "EXR metadata"; }
# A second Ctrl-C ends the process at once, leaving no temporary file.
"$volux" render procedural:sphere:24 --technique pathtrace --spp 1000000 --width 48 --height 48 \
  -o "$tmp/twice.png" 2>/dev/null &
pid=$!
sleep 1
kill -INT "$pid"
kill -INT "$pid"
wait "$pid"
rc=$?
[[ $rc == 130 ]] || bad "two SIGINTs: exit $rc, want 130"
ls "$tmp" | grep -q 'tmp' && bad "a temporary file was left: $(ls "$tmp")"

# ---- small points
expect 2 "did you mean 'pathtrace'" "$volux" render procedural:sphere:8 --technique pathtracer -o "$tmp/t.png"
expect 2 "preintegrate" "$volux" render procedural:sphere:8 --set techniques.ea.preintegrat=1 -o "$tmp/t.png"
expect 0 "anti-aliasing" "$volux" render procedural:sphere:8 --technique shaded --spp 2 "${small[@]}" -o "$tmp/t.png"
expect 0 "rel. error n/a" "$volux" render procedural:sphere:8 --technique pathtrace --spp 2 "${small[@]}" -o "$tmp/t.png"
"$volux" techniques ambient >"$tmp/out" 2>&1 || bad "volux techniques ambient failed"
grep -q '^ambient ' "$tmp/out" || bad "volux techniques ambient does not show ambient"
grep -q '^pathtrace ' "$tmp/out" && bad "volux techniques ambient lists other techniques"
expect 2 "unknown technique 'nope'" "$volux" techniques nope
expect 2 "did you mean 'pathtrace'" "$volux" techniques pathtracer

# volux info on images: a Radiance .hdr is an image, not a NIfTI header.
printf '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n\x80\x80\x80\x81\x80\x80\x80\x81' >"$tmp/env.hdr"
expect 0 "" "$volux" info "$tmp/env.hdr"
grep -q "^image *2 x 1" "$tmp/out" || bad "volux info env.hdr: $(cat "$tmp/out")"
expect 0 "" "$volux" info "$tmp/q.pfm"
grep -q "^image *32 x 32" "$tmp/out" || bad "volux info q.pfm: $(cat "$tmp/out")"
expect 2 "a Radiance HDR image, not a volume" "$volux" render "$tmp/env.hdr" -o "$tmp/e.png"
printf 'garbage' >"$tmp/bad.hdr"
expect 2 "bad.hdr" "$volux" info "$tmp/bad.hdr"

exit $fail
