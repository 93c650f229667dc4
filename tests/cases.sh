# The cases of a command-line suite in bash, as tests/cases.py has them for Python (docs/testing.md
# "Cases and the sanitizer sample"). Source it, then:
#   cases_init SUITE
#   if case_begin NAME; then ...the case's checks...; fi
#   cases_finish      # fails the suite (via expect.sh's fail) on a stale sample
# In release every case runs; with DRIVETAP_SAMPLE (the sanitizer build) a case the sample marks
# `skip` does not; a case it does not list is new, and runs. With DRIVETAP_CASE_PROFILES
# (scripts/choose_sample.py) each case's drivetap processes write their coverage to a folder of
# their own, and its wall time to that folder's `seconds`.

cases_init() {
  cases_suite=$1
  cases_met=" "
  cases_current=""
  cases_ran=0
  cases_skipped=0
  cases_new=0
  cases_outside=${LLVM_PROFILE_FILE:-}
  declare -gA cases_marks=()
  if [ -n "${DRIVETAP_SAMPLE:-}" ]; then
    local mark suite name rest
    while read -r mark suite name rest; do
      case "$mark" in run | skip) ;; *) continue ;; esac
      [ "$suite" = "$cases_suite" ] && cases_marks[$name]=$mark
    done < "$DRIVETAP_SAMPLE"
  fi
}

cases_close_() {
  if [ -n "$cases_current" ] && [ -n "${DRIVETAP_CASE_PROFILES:-}" ]; then
    local folder=$DRIVETAP_CASE_PROFILES/$cases_suite/$cases_current
    awk -v s="$cases_started" -v e="$(date +%s.%N)" 'BEGIN { printf "%.3f\n", e - s }' \
      >> "$folder/seconds"
  fi
  cases_current=""
  # (the work outside every case writes where the chooser said: cases_outside)
  if [ -n "${DRIVETAP_CASE_PROFILES:-}" ]; then
    if [ -n "$cases_outside" ]; then export LLVM_PROFILE_FILE=$cases_outside; else unset LLVM_PROFILE_FILE; fi
  fi
  return 0
}

case_begin() {
  local name=${1//[^A-Za-z0-9_.:+-]/_}
  cases_close_
  if [[ "$cases_met" == *" $name "* ]]; then
    echo "$cases_suite: case $name named twice" >&2
    exit 1
  fi
  cases_met="$cases_met$name "
  if [ -n "${DRIVETAP_SAMPLE:-}" ]; then
    case "${cases_marks[$name]:-}" in
      skip) cases_skipped=$((cases_skipped + 1)); return 1 ;;
      "") cases_new=$((cases_new + 1)) ;;
    esac
  fi
  cases_ran=$((cases_ran + 1))
  if [ -n "${DRIVETAP_CASE_PROFILES:-}" ]; then
    mkdir -p "$DRIVETAP_CASE_PROFILES/$cases_suite/$name"
    export LLVM_PROFILE_FILE="$DRIVETAP_CASE_PROFILES/$cases_suite/$name/%p-%m.profraw"
    cases_current=$name
    cases_started=$(date +%s.%N)
  fi
  return 0
}

cases_finish() {
  cases_close_
  [ -n "${DRIVETAP_SAMPLE:-}" ] || return 0
  local name
  for name in "${!cases_marks[@]}"; do
    if [ "${cases_marks[$name]}" = run ] && [[ "$cases_met" != *" $name "* ]]; then
      fail "$cases_suite: the sanitizer sample runs case $name, which the suite no longer has: run scripts/choose_sample.py"
    fi
  done
  echo "$cases_suite: sample: $cases_ran of $((cases_ran + cases_skipped)) cases run ($cases_new new since the sample was chosen)"
}
