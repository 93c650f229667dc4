# Shared by the command-line test scripts (tests/faults.sh, tests/hostile.sh): a failure
# counter and checks of one command's exit status and stderr. The sourcing script sets $work (a
# scratch directory) and reports $failures at its end.
failures=0
fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}
ok() { echo "ok: $*"; }
# expect NAME CODE PATTERN -- COMMAND...: exit status CODE, exactly one stderr line matching
# PATTERN (or, with PATTERN '', no stderr at all).
expect() {
  local name=$1 code=$2 pattern=$3
  shift 4
  timeout 60 "$@" > "$work/out" 2> "$work/err"
  local rc=$?
  local lines
  lines=$(wc -l < "$work/err")
  local bad=0
  [ "$rc" -eq "$code" ] || { fail "$name: exit $rc, expected $code ($(head -c 300 "$work/err"))"; bad=1; }
  if [ -z "$pattern" ]; then
    [ "$lines" -eq 0 ] || { fail "$name: stderr not empty: $(head -c 300 "$work/err")"; bad=1; }
  else
    [ "$lines" -eq 1 ] || { fail "$name: $lines stderr lines, expected one: $(head -c 300 "$work/err")"; bad=1; }
    grep -qE -- "$pattern" "$work/err" || { fail "$name: stderr '$(head -c 300 "$work/err")' lacks /$pattern/"; bad=1; }
  fi
  [ "$bad" = 0 ] && ok "$name"
}
# The last stderr line only (a read prints its notes before an error).
expect_last() {
  local name=$1 code=$2 pattern=$3
  shift 4
  timeout 60 "$@" > "$work/out" 2> "$work/err"
  local rc=$?
  if [ "$rc" -ne "$code" ]; then fail "$name: exit $rc, expected $code ($(tail -c 300 "$work/err"))"; return; fi
  if ! tail -n 1 "$work/err" | grep -qE -- "$pattern"; then
    fail "$name: last stderr line '$(tail -n 1 "$work/err")' lacks /$pattern/"
    return
  fi
  ok "$name"
}
