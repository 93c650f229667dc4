#!/usr/bin/env bash
# `cmake --install`: drivetap, its manual page, its bash completion and its Wireshark extcap link
# land where they belong;
# the page renders without groff warnings and names every option each command's --help lists;
# the completion completes commands, a misspelt-free option list per command, and -t's values.
#   tests/install.sh BUILD_DIR SOURCE_DIR
set -uo pipefail
build="$1"
source="$2"
failed=0
fail() { echo "FAIL: $*"; failed=1; }
prefix=$(mktemp -d)
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix" > /dev/null || fail "cmake --install"
bin="$prefix/bin/drivetap"
page=$(ls "$prefix"/share/man/man1/drivetap.1 2>/dev/null)
completion="$prefix/share/bash-completion/completions/drivetap"
[ -x "$bin" ] || fail "no bin/drivetap"
[ -n "$page" ] || fail "no share/man/man1/drivetap.1"
[ -f "$completion" ] || fail "no share/bash-completion/completions/drivetap"
# The Wireshark extcap: a link to the installed binary, which acts as an extcap by its name.
extcap=$(ls "$prefix"/lib*/wireshark/extcap/drivetap-extcap "$prefix"/lib/*/wireshark/extcap/drivetap-extcap 2>/dev/null | head -1)
if [ -z "$extcap" ] || [ ! -L "$extcap" ]; then
  fail "no lib/.../wireshark/extcap/drivetap-extcap link"
else
  [ "$(readlink -f "$extcap")" = "$(readlink -f "$bin")" ] || fail "drivetap-extcap links to $(readlink -f "$extcap")"
  "$extcap" --extcap-dlts --extcap-interface /dev/ttyUSB0 | grep -q '^dlt {number=252}' ||
    fail "drivetap-extcap --extcap-dlts: $("$extcap" --extcap-dlts --extcap-interface /dev/ttyUSB0 2>&1)"
fi

if command -v groff > /dev/null; then
  warnings=$(groff -man -ww -z "$page" 2>&1)
  [ -z "$warnings" ] || fail "groff warnings: $warnings"
  rendered=$(groff -man -Tutf8 "$page" 2>/dev/null | sed 's/\x08.//g; s/‐/-/g')
  for command in decode read diagnose capture; do
    for option in $("$bin" "$command" --help | grep -E '^  -' | awk '{print $1}' |
                    tr ',' '\n' | sort -u); do
      case "$option" in -h | --help) continue ;; esac
      grep -q -- "$option" <<<"$rendered" || fail "drivetap.1 does not name $command's $option"
    done
  done
fi

# The completion, run as bash runs it (no bash-completion package needed).
complete_line() {
  bash -c '
    source "$1"; shift
    COMP_WORDS=("$@"); COMP_CWORD=$(($# - 1))
    _drivetap
    [ ${#COMPREPLY[@]} -eq 0 ] || printf "%s\n" "${COMPREPLY[@]}"' _ "$completion" "$@"
}
got=$(complete_line "$bin" re | tr '\n' ' ')
[ "$got" = "read report " ] || fail "completion of 're': $got"
got=$(complete_line "$bin" rea | tr '\n' ' ')
[ "$got" = "read " ] || fail "completion of 'rea': $got"
got=$(complete_line "$bin" diagnose --co | tr '\n' ' ')
[ "$got" = "--color " ] || fail "completion of 'diagnose --co': $got"
got=$(complete_line "$bin" diagnose -w | tr '\n' ' ')
[ -z "$got" ] || fail "completion offers -w to diagnose: $got"
got=$(complete_line "$bin" read --no-p | tr '\n' ' ')
[ "$got" = "--no-progress " ] || fail "completion of 'read --no-p': $got"
got=$(complete_line "$bin" read -t a | tr '\n' ' ')
[ "$got" = "ad a " ] || fail "completion of 'read -t a': $got"
[ "$failed" = 0 ] && echo "install: all checks pass"
exit "$failed"
