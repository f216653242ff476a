# Sourced by scripts/test: compiles a CMake preset in the background on the processor time
# nothing else wants, so that one tree is built while the tree before it is tested. The suites
# mostly wait (on child processes, sockets, a meter's pacing), and a build at the kernel's idle
# scheduling class (SCHED_IDLE, chrt --idle) runs only in those gaps: a suite that wakes takes
# the processor back at once, so its deadlines are kept as if it ran alone.
# Usage: idle_build_start PRESET JOBS; idle_build_finish (waits for it, then prints its log's
# tail if it failed, and fails too); idle_build_stop (on EXIT: ends a build still running).

idle_build_pid=""
idle_build_log=""

idle_build_start() {
  local preset=$1 jobs=$2 idle=(nice -n 19)
  if chrt --idle 0 true 2>/dev/null; then idle=(chrt --idle 0); fi
  idle_build_log="build/$preset.build.log"
  # In a session of its own, so that idle_build_stop reaches ninja and its compilers at once.
  setsid "${idle[@]}" cmake --build --preset "$preset" -j"$jobs" >"$idle_build_log" 2>&1 </dev/null &
  idle_build_pid=$!
}

idle_build_finish() {
  local pid=$idle_build_pid status=0
  idle_build_pid=""
  wait "$pid" || status=$?
  if [ "$status" -ne 0 ]; then
    tail -n 60 "$idle_build_log" >&2
    echo "build failed (status $status): the whole log is $idle_build_log" >&2
  fi
  return "$status"
}

idle_build_stop() {
  [ -n "$idle_build_pid" ] || return 0
  # ninja, stopped, ends the compilers it started and removes what they had begun to write.
  kill -TERM -- "-$idle_build_pid" 2>/dev/null || true
  wait "$idle_build_pid" 2>/dev/null || true
  idle_build_pid=""
}
