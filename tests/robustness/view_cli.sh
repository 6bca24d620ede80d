#!/usr/bin/env bash
# tests/robustness/view_cli.sh VOLUX SRC — `volux view VOLUME` (issue 18):
# the quick-look scene is served (GET /api/scene names the volume), a
# SIGTERM ends it with status 0 and removes its temporary scene folder, and
# bad input is exit 2 with a message and nothing left behind.
set -u
VOLUX=$1
T=$(mktemp -d)
trap 'rm -rf "$T"; [ -n "${pid:-}" ] && kill "$pid" 2>/dev/null' EXIT
export TMPDIR=$T/tmp OMP_WAIT_POLICY=passive
mkdir -p "$TMPDIR"
fail=0
check() { if eval "$1"; then echo "ok: $2"; else echo "FAIL: $2"; fail=1; fi; }

"$VOLUX" view procedural:marschner_lobb:24 --port 0 --bind 127.0.0.1 >"$T/out" 2>"$T/err" &
pid=$!
port=""
for _ in $(seq 100); do
  port=$(grep -o '127\.0\.0\.1:[0-9]*' "$T/out" 2>/dev/null | head -1 | cut -d: -f2)
  [ -n "$port" ] && break
  sleep 0.1
done
check "[ -n '$port' ]" "view printed its URL"
if [ -n "$port" ]; then
  exec 3<>"/dev/tcp/127.0.0.1/$port"
  printf 'GET /api/scene HTTP/1.1\r\nHost: 127.0.0.1:%s\r\nConnection: close\r\n\r\n' "$port" >&3
  timeout 10 cat <&3 >"$T/scene"
  exec 3>&-
  check "grep -q '200 OK' '$T/scene' && grep -q 'marschner_lobb' '$T/scene'" "the quick-look scene is served"
  check "[ \$(ls '$TMPDIR' | wc -l) = 1 ]" "one temporary scene folder while serving"
  exec 3<>"/dev/tcp/127.0.0.1/$port"
  printf 'GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:%s\r\nConnection: close\r\n\r\n' "$port" >&3
  timeout 10 cat <&3 >"$T/state"
  exec 3>&-
  check "grep -q 'scene_path\": *\"procedural:marschner_lobb:24 (quick look)' '$T/state'" "the page names the volume"
  check "! grep -q 'volux-view-' '$T/state' '$T/err'" "the temporary scene path is shown nowhere"
fi
kill -TERM "$pid"
wait "$pid"; rc=$?
pid=""
check "[ $rc = 0 ]" "SIGTERM: exit status 0 (got $rc)"
check "[ \$(ls '$TMPDIR' | wc -l) = 0 ]" "the temporary scene folder is removed"

"$VOLUX" view "$T/missing.nhdr" --port 0 2>"$T/err"; rc=$?
check "[ $rc = 2 ] && grep -q 'missing.nhdr' '$T/err'" "missing volume: exit 2 naming it (got $rc)"
check "[ \$(ls '$TMPDIR' | wc -l) = 0 ]" "missing volume: nothing left behind"
"$VOLUX" view 2>"$T/err"; rc=$?
check "[ $rc = 2 ] && grep -q 'missing VOLUME' '$T/err'" "no argument: exit 2 with a message"
exit $fail
