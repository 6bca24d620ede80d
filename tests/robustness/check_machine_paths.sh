#!/bin/bash
# No tracked file names a place on one particular machine (issue 18): the
# shared data is reached through $VOLUX_DATA (docs/CONVENTIONS.md), never
# by an absolute path, so a fresh clone works anywhere. Refused:
#   - the checkout's own absolute path (a result table that recorded
#     where it ran, a scene written with realpath);
#   - paths under the usual per-machine roots (/work, /home, /Users, /root,
#     /mnt, /media, /srv, /scratch, /nfs);
#   - in JSON files, any string value that is an absolute path (a scene's
#     file names resolve against its folder or $VOLUX_DATA), except the
#     fuzz corpora's deliberately hostile inputs.
# System paths in scripts (/usr/bin/python3, /dev/null, /tmp) are fine.
# Known fakes (a test's made-up HOME) are listed in ALLOWED.
# Usage: check_machine_paths.sh VOLUX SRC_DIR   (VOLUX unused; ctest passes it)
set -u
root=${2:?usage: check_machine_paths.sh VOLUX SRC_DIR}
cd "$root" || exit 1
here=$(pwd -P)

MACHINE_ROOTS='(^|[^A-Za-z0-9_.~$-])/(work|home|Users|root|mnt|media|srv|scratch|nfs)/[A-Za-z0-9_.-]'
ALLOWED='/home/someone' # tests/unit/test_context.c: a fake HOME for the cache-folder test

# scan FILE...: prints "file:line:text" for every offending line.
scan() {
  local json=()
  local f
  # fuzz corpora hold hostile inputs on purpose (an edit naming /etc/passwd)
  for f in "$@"; do [[ $f == *.json && $f != fuzz/corpus/* ]] && json+=("$f"); done
  grep -nIHE "$MACHINE_ROOTS" -- "$@" 2>/dev/null | grep -vF "$ALLOWED"
  grep -nIHF "$here/" -- "$@" 2>/dev/null
  ((${#json[@]})) && grep -nIHE '"/[A-Za-z]' -- "${json[@]}" 2>/dev/null
  return 0
}

# The check must be able to fail: planted offenders are found, a clean
# file is not.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '{"volume": {"file": "/data/ct/head.nhdr"}}\n' >"$tmp/abs.json"
printf 'DATA=/%s/shared/data/volumes\n' work >"$tmp/root.sh" # (split, or this file would hold one)
printf 'see %s/bench/x.json\n' "$here" >"$tmp/self.txt"
printf '{"volume": {"file": "$VOLUX_DATA/volumes/a.nhdr"}}\nexec /usr/bin/python3 /tmp/x\n' >"$tmp/clean.json"
for f in abs.json root.sh self.txt; do
  if [[ -z $(scan "$tmp/$f") ]]; then
    echo "check_machine_paths: self-test: the planted $f was not found" >&2
    exit 1
  fi
done
if [[ -n $(scan "$tmp/clean.json") ]]; then
  echo "check_machine_paths: self-test: a clean file was refused: $(scan "$tmp/clean.json")" >&2
  exit 1
fi

if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files)
else # an exported tree: everything but build outputs
  mapfile -t files < <(find . -type f -not -path './build*' -not -path './out/*' -not -path './.git/*' | sed 's|^\./||')
fi
found=$(scan "${files[@]}")
if [[ -n $found ]]; then
  echo "check_machine_paths: absolute machine paths in tracked files (use \$VOLUX_DATA/... or a relative path):" >&2
  echo "$found" >&2
  exit 1
fi
echo "check_machine_paths: ${#files[@]} files, no machine paths"
