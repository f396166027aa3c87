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

# `expect_bounded CODE MIB SECONDS PATTERN DESCRIPTION COMMAND...`: the adversarial suite's check.
# Runs COMMAND with its address space capped at MIB MiB (prlimit --as) and killed after SECONDS;
# asserts the exit status CODE (never a signal: 128+N fails unless CODE asks for it), and for
# CODE != 0 exactly one "csgv: error:" line that matches the extended regex PATTERN (case
# insensitive). The child's stderr stays in $TMP/err for further checks.
expect_bounded() {
  local want=$1 mib=$2 secs=$3 pattern=$4 what=$5; shift 5
  prlimit --as=$((mib * 1024 * 1024)) -- timeout -s KILL "$secs" "$@" >"$TMP/out" 2>"$TMP/err"
  local got=$?
  if [ "$got" -eq 137 ] && [ "$want" -ne 137 ]; then bad "$what: killed after ${secs}s (time ceiling)"; return; fi
  if [ "$got" -ne "$want" ]; then bad "$what: exit $got, expected $want ($(head -c 300 "$TMP/err"))"; return; fi
  if [ "$want" -ne 0 ]; then
    if [ "$(grep -c '^csgv: error: ' "$TMP/err")" -ne 1 ]; then
      bad "$what: stderr is not one clear error line: $(head -c 600 "$TMP/err")"; return
    fi
    if ! grep '^csgv: error: ' "$TMP/err" | grep -Eqi -- "$pattern"; then
      bad "$what: message does not match /$pattern/: $(grep '^csgv: error: ' "$TMP/err")"; return
    fi
  fi
  pass "$what"
}

# `expect_interrupt DESCRIPTION COMMAND...`: starts COMMAND, sends SIGINT (or $INTERRUPT_SIGNAL:
# TERM, HUP) after it has run a second, and asserts it exits with status 130 within one more second.
expect_interrupt() {
  local what=$1; shift
  local sig=${INTERRUPT_SIGNAL:-INT}
  "$@" >"$TMP/out" 2>"$TMP/err" &
  local pid=$!
  sleep 1
  if ! kill -0 "$pid" 2>/dev/null; then wait "$pid"; bad "$what: ended before the interrupt (exit $?)"; return; fi
  local t0; t0=$(date +%s%N)
  kill -"$sig" "$pid"
  local waited=0
  while kill -0 "$pid" 2>/dev/null && [ "$waited" -lt 50 ]; do sleep 0.05; waited=$((waited + 1)); done
  if kill -0 "$pid" 2>/dev/null; then kill -KILL "$pid"; wait "$pid"; bad "$what: still running 2.5 s after SIG$sig"; return; fi
  wait "$pid"; local got=$?
  local ms=$((($(date +%s%N) - t0) / 1000000))
  if [ "$got" -ne 130 ]; then bad "$what: exit $got after SIG$sig, expected 130 ($(head -c 300 "$TMP/err"))"; return; fi
  if [ "$ms" -gt 1000 ]; then bad "$what: took ${ms} ms to end after SIG$sig"; return; fi
  pass "$what (${ms} ms)"
}
