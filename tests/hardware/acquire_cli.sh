#!/bin/sh
# End-to-end checks of `pvdfkit acquire` without hardware: the simulator, recording and replay,
# Ctrl-C (exit 130, everything received written out), a run killed with SIGKILL (its recording
# still replays), and one-line errors with exit 2.  Usage: acquire_cli.sh PVDFKIT WORKDIR
set -u
P=$1
W=$2
mkdir -p "$W"
fail() { echo "FAIL: $*"; exit 1; }
lines() { wc -l < "$1" | tr -d ' '; }

# 1. Built-in simulation: header + 10000 rows, exit 0.
"$P" acquire --device sim: --quiet --output "$W/sim.csv" || fail "sim exit $?"
[ "$(lines "$W/sim.csv")" = 10001 ] || fail "sim rows $(lines "$W/sim.csv")"
head -1 "$W/sim.csv" | grep -qx 't_s,ch0_V,ch1_V,ch2_V' || fail "sim header"

# 2. Record and replay give the same CSV.
"$P" acquire --device sim: --quiet --record "$W/a.pvdfrec" --output "$W/a.csv" || fail "record exit $?"
"$P" acquire --device replay:"$W/a.pvdfrec" --quiet --output "$W/b.csv" || fail "replay exit $?"
cmp -s "$W/a.csv" "$W/b.csv" || fail "replay differs from the recorded run"

# Waits (at most 60 s) until FILE holds at least BYTES bytes: a signal is sent only once the run is
# really recording frames (process start alone can take seconds on a loaded machine, and a background
# job of a non-interactive shell ignores SIGINT until pvdfkit installs its handler).
wait_for_bytes() {
  local file=$1 bytes=$2 i
  for i in $(seq 600); do
    [ -f "$file" ] && [ "$(stat -c %s "$file")" -ge "$bytes" ] && return 0
    sleep 0.1
  done
  fail "$file did not reach $bytes bytes within 60 s"
}

# 3. Ctrl-C during a real-time run: exit 130, CSV and recording hold the same samples.
printf '{"duration_s": 30}\n' > "$W/long.json"
rm -f "$W/int.pvdfrec" "$W/int.csv"   # a stale file from an earlier run would end the wait at once
"$P" acquire --device sim:"$W/long.json" --realtime --quiet --record "$W/int.pvdfrec" --output "$W/int.csv" &
pid=$!
wait_for_bytes "$W/int.pvdfrec" 16384   # frames on disk: past the header, the Ctrl-C handler is installed
kill -INT $pid
wait $pid
code=$?
[ $code = 130 ] || fail "Ctrl-C exit $code"
n=$(lines "$W/int.csv")
[ "$n" -gt 1 ] || fail "Ctrl-C wrote no rows"
"$P" acquire --device replay:"$W/int.pvdfrec" --quiet --output "$W/int2.csv" || fail "replay after Ctrl-C"
cmp -s "$W/int.csv" "$W/int2.csv" || fail "recording after Ctrl-C differs from the CSV"

# 4. SIGKILL: no chance to clean up; the recording still replays every complete frame.
rm -f "$W/kill.pvdfrec" "$W/kill.csv"
"$P" acquire --device sim:"$W/long.json" --realtime --quiet --record "$W/kill.pvdfrec" --output "$W/kill.csv" &
pid=$!
wait_for_bytes "$W/kill.pvdfrec" 32768
kill -KILL $pid
wait $pid 2>/dev/null
"$P" acquire --device replay:"$W/kill.pvdfrec" --quiet --output "$W/kill2.csv" 2> "$W/kill2.err" || fail "replay after SIGKILL exit $?"
n=$(lines "$W/kill2.csv")
[ "$n" -gt 1000 ] || fail "recording of the killed run has only $n rows"
[ $(( (n - 1) % 100 )) = 0 ] || fail "killed run replays a partial frame ($n rows)"

# 5. Errors: one line, exit 2.
for args in "--device bogus" "--device replay:$W/missing.pvdfrec" "--device usb:12" "--device sim: --rate-Hz 5000" \
            "--device sim: --locate $W/missing.h5" "--device sim: --restore $W/missing.json"; do
  "$P" acquire $args > /dev/null 2> "$W/err.txt"
  code=$?
  [ $code = 2 ] || fail "'$args' exit $code"
  [ "$(lines "$W/err.txt")" = 1 ] || fail "'$args' printed $(lines "$W/err.txt") lines"
  grep -q '^error: ' "$W/err.txt" || fail "'$args' message: $(cat "$W/err.txt")"
done
echo "acquire CLI: all checks passed"
