# SPDX-License-Identifier: MIT
# Shared by the `csgv` interface tests (sourced): a scratch folder, pass/fail counters, and
# `expect CODE DESCRIPTION COMMAND...` checking the exit status and, for errors, exactly one
# "csgv: error:" line on stderr. `finish` prints the counts and sets the exit status.
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
fails=0
passes=0
pass() { echo "ok: $1"; passes=$((passes + 1)); }
bad() { echo "FAIL: $1"; fails=$((fails + 1)); }

expect() {
  local want=$1 what=$2; shift 2
  "$@" >"$TMP/out" 2>"$TMP/err"; local got=$?
  if [ "$got" -ne "$want" ]; then bad "$what: exit $got, expected $want ($(head -c 300 "$TMP/err"))"; return; fi
  if [ "$want" -ne 0 ] && [ "$(grep -c '^csgv: error: ' "$TMP/err")" -ne 1 ]; then
    bad "$what: stderr is not one clear error line: $(cat "$TMP/err")"; return
  fi
  pass "$what"
}

finish() {
  echo "$passes passed, $fails failed"
  [ "$fails" -eq 0 ]
}
