#!/usr/bin/env bash
# tests/robustness/http_redteam.sh VOLUX SRC — runs http_redteam.py (issue 34's
# HTTP attacks on `volux serve` over loopback, < ~60 s) with Debian's python3
# (standard library only; `make test-deps` installs it).
set -u
PY=$(command -v /usr/bin/python3 || command -v python3)
if [ -z "$PY" ]; then echo "FAIL: python3 not found"; exit 1; fi
exec timeout 300 "$PY" "$2/tests/robustness/http_redteam.py" "$1"
