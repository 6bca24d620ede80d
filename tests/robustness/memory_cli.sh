#!/bin/bash
# The memory budget at the command line (issue 29, docs/SCALE.md): a render
# whose estimate exceeds the limit stops before any cache or framebuffer is
# allocated, exit 2, the estimate and the limit named, no output file and
# no temporary left; --memory-limit is validated; one that fits renders;
# `volux bench` reports memory_bytes beside the model's estimate.
# Usage: memory_cli.sh VOLUX SRC_DIR
set -u
volux=${1:?usage: memory_cli.sh VOLUX SRC_DIR}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_WAIT_POLICY=passive
fail=0
bad() { echo "FAIL: $*" >&2; fail=1; }

expect() {
  local want=$1 text=$2
  shift 2
  "$@" >"$tmp/out" 2>"$tmp/err"
  local got=$?
  [[ $got == "$want" ]] || bad "$* -> exit $got, want $want: $(cat "$tmp/err")"
  [[ -z $text ]] || grep -qF -- "$text" "$tmp/err" || bad "$* -> stderr lacks '$text': $(cat "$tmp/err")"
}
no_output() { # no file and no PATH.tmp-XXXXXX beside it
  local leftovers
  leftovers=$(ls "$tmp" | grep -F "$1" || true)
  [[ -z $leftovers ]] || bad "$2 left: $leftovers"
}

vol=procedural:phantom:32
# ---- 30000² (39.6 GB of framebuffer and image) under an 8 GiB limit
start=$SECONDS
expect 2 "more than the memory limit of 8.6 GB (8589934592 bytes)" \
  "$volux" render $vol --technique ea --width 30000 --height 30000 --memory-limit 8G -o "$tmp/big.png"
grep -qF "needs an estimated 39.6 GB" "$tmp/err" || bad "the estimate is not named: $(cat "$tmp/err")"
((SECONDS - start < 20)) || bad "the refusal took $((SECONDS - start)) s: it allocated or rendered first"
no_output big.png "a refused render"
# the default limit (80 % of physical memory) refuses the largest image,
# 32768² (47 GB), on any machine with less than ~59 GB
if (($(awk '/MemTotal/ {print $2}' /proc/meminfo) < 55000000)); then
  expect 2 "80% of physical memory" "$volux" render $vol --technique ea --width 32768 --height 32768 -o "$tmp/huge.exr"
  no_output huge.exr "a refused render (default limit)"
fi
# the technique's caches count: lightvol at 64³ needs ~7 MB of caches
expect 2 "technique caches" "$volux" render procedural:phantom:64 --technique lightvol --width 16 --height 16 \
  --memory-limit 4M -o "$tmp/lv.pfm"
no_output lv.pfm "a refused lightvol render"
# bench refuses as render does
expect 2 "memory limit" "$volux" bench $vol --technique ea --width 30000 --height 30000 --memory-limit 1G --repeat 1

# ---- --memory-limit is validated
for v in abc 0 -5 12Q 1.5X "" 1e30; do
  expect 2 "--memory-limit" "$volux" render $vol --memory-limit "$v" -o "$tmp/v.png"
done
expect 2 "--memory-limit needs a size" "$volux" render $vol -o "$tmp/v.png" --memory-limit
no_output v.png "a bad --memory-limit"

# ---- one that fits renders, in every unit spelling
for v in 512M 0.5G 524288K 512MiB none 536870912; do
  expect 0 "" "$volux" render $vol --technique ea --width 64 --height 64 --memory-limit "$v" -o "$tmp/ok.png" --quiet
  [[ -s $tmp/ok.png ]] || bad "--memory-limit $v: no image"
  rm -f "$tmp/ok.png"
done

# ---- the limit is a budget over every allocation (issue 34 D5): a volume
# the estimate never sees (here the scene's own, 128³ = 2 MiB) is refused by
# the allocator with the limit's message, exit 2; the viewer's --max-mb is
# the same budget (before, serve ignored --memory-limit and --max-mb capped
# one allocation only)
expect 2 "memory limit reached" "$volux" render procedural:phantom:128 --technique ea --width 16 --height 16 \
  --memory-limit 1M -o "$tmp/budget.png"
no_output budget.png "a render over the budget"
expect 2 "1048576 bytes" timeout 20 "$volux" view procedural:phantom:128 --port 0 --max-mb 1
expect 2 "1048576 bytes" timeout 20 "$volux" view procedural:phantom:128 --port 0 --memory-limit 1M
expect 2 "memory limit reached" timeout 20 "$volux" view procedural:phantom:96 --port 0 --max-mb 1
expect 2 "give one" timeout 20 "$volux" view procedural:phantom:128 --port 0 --memory-limit 1M --max-mb 1

# ---- bench: memory_bytes with the estimate beside it
"$volux" bench $vol --technique lightvol --width 16 --height 16 --repeat 1 --edit camera --json >"$tmp/b.jsonl" 2>/dev/null ||
  bad "bench failed"
python3 - "$tmp/b.jsonl" <<'PY' || bad "bench memory metrics"
import json, sys
m = {}
for line in open(sys.argv[1]):
    d = json.loads(line)
    m[d["metric"]] = d
mb, est = m["memory_bytes"]["value"], m["memory_bytes"]["estimate"]
assert abs(est - mb) <= 0.1 * mb, (mb, est)
assert abs(m["memory_estimate_bytes"]["value"] - est) <= 1e-5 * est
assert m["memory_estimate_total_bytes"]["value"] > est
assert m["peak_rss_bytes"]["value"] > mb
PY
exit $fail
