#!/usr/bin/env bash
# Long runs with flat memory: runs one command, samples its resident memory
# from /proc/PID/status, and fails when it grew by more than the bound.
#
#   scripts/longrun.sh LABEL BOUND_KIB COMMAND...
#
# "start" is the first sample taken once the process has run START_S seconds
# (setup done, first frames rendered); "end" is the last sample before it
# exits. Growth = end VmRSS - start VmRSS. VmHWM (the peak) is reported too.
set -u
label=$1; bound_kib=$2; shift 2
START_S=${START_S:-2}
"$@" >/dev/null 2>"/tmp/longrun-$$.err" &
pid=$!
t0=$(date +%s.%N)
start_rss=""; start_hwm=""; end_rss=""; end_hwm=""
# The process of interest may be a child (xvfb-run): follow the newest
# descendant named penumbra.
target_pid() {
  local p
  p=$(pgrep -n -P "$pid" penumbra 2>/dev/null || true)
  if [ -z "$p" ]; then
    for c in $(pgrep -P "$pid" 2>/dev/null); do
      p=$(pgrep -n -P "$c" penumbra 2>/dev/null || true)
      [ -n "$p" ] && break
    done
  fi
  echo "${p:-$pid}"
}
while kill -0 "$pid" 2>/dev/null; do
  tp=$(target_pid)
  status=$(cat "/proc/$tp/status" 2>/dev/null) || { sleep 0.1; continue; }
  [ "$(awk '/^Name:/ {print $2}' <<<"$status")" = penumbra ] || { sleep 0.1; continue; }
  rss=$(awk '/^VmRSS:/ {print $2}' <<<"$status")
  hwm=$(awk '/^VmHWM:/ {print $2}' <<<"$status")
  [ -z "$rss" ] && { sleep 0.1; continue; }
  elapsed=$(echo "$(date +%s.%N) - $t0" | bc)
  if [ -z "$start_rss" ] && [ "$(echo "$elapsed >= $START_S" | bc)" = 1 ]; then
    start_rss=$rss; start_hwm=$hwm; start_t=$elapsed
  fi
  end_rss=$rss; end_hwm=$hwm; end_t=$elapsed
  sleep 0.1
done
wait "$pid"; rc=$?
total=$(echo "$(date +%s.%N) - $t0" | bc)
if [ "$rc" != 0 ]; then
  echo "$label: exited with $rc"; cat "/tmp/longrun-$$.err"; rm -f "/tmp/longrun-$$.err"; exit 1
fi
rm -f "/tmp/longrun-$$.err"
if [ -z "$start_rss" ]; then
  echo "$label: finished in ${total}s, before the first sample at ${START_S}s; lower START_S"; exit 1
fi
growth=$((end_rss - start_rss))
printf '%s: %.1f s; VmRSS %d KiB at %.1f s -> %d KiB at %.1f s (growth %d KiB, bound %d KiB); VmHWM %d -> %d KiB\n' \
  "$label" "$total" "$start_rss" "$start_t" "$end_rss" "$end_t" "$growth" "$bound_kib" "$start_hwm" "$end_hwm"
if [ "$growth" -gt "$bound_kib" ]; then
  echo "$label: FAIL: resident memory grew by $growth KiB (> $bound_kib KiB)"; exit 1
fi
