# Sourced by scripts/demo and scripts/test: runs named phases and prints each one's wall time,
# the phase a failure stopped in included, so that a slow phase is seen.
# Usage: phase NAME COMMAND [ARG...]; phase_report (once; scripts also call it on EXIT).
# A failing command ends the script as `set -e` would anywhere else: phase is not a condition.

phase_names=()
phase_seconds=()
phase_current=""
phase_started=""
phase_reported=""

phase_elapsed() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }

phase() {
  phase_current=$1
  phase_started=$(date +%s.%N)
  shift
  "$@"
  phase_names+=("$phase_current")
  phase_seconds+=("$(phase_elapsed "$phase_started")")
  phase_current=""
}

phase_report() {
  local i total=0
  [ -z "$phase_reported" ] || return 0
  phase_reported=1
  if [ -n "$phase_current" ]; then
    phase_names+=("$phase_current (stopped)")
    phase_seconds+=("$(phase_elapsed "$phase_started")")
    phase_current=""
  fi
  [ ${#phase_names[@]} -gt 0 ] || return 0
  echo "== wall time by phase"
  for i in "${!phase_names[@]}"; do
    printf '%-24s %8s s\n' "${phase_names[$i]}" "${phase_seconds[$i]}"
    total=$(awk -v a="$total" -v b="${phase_seconds[$i]}" 'BEGIN { printf "%.1f", a + b }')
  done
  printf '%-24s %8s s\n' "total" "$total"
}
