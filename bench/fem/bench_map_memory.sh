#!/bin/sh
# Resident memory of a map against the positions it has solved (issue 34, docs/bench-fem.md
# "Memory"): runs `pvdfkit map` (or any pvdfkit command with a progress line on stderr) under
# /usr/bin/time -v, samples VmRSS every 3 s, and prints one table row per progress line:
# positions solved, elapsed, RSS then, largest RSS so far; then the peak and the CPU time.
#
#   bench/fem/bench_map_memory.sh EXE OUT_PREFIX ARGS...         (run from the repository root)
#   e.g. the clamp rows of the README's second map (the reproduction of docs/bench-fem.md):
#   bench/fem/bench_map_memory.sh build/app/pvdfkit /tmp/m2 map examples/scenes/four-electrodes-45deg.json \
#       --spacing-m 0.004 --region=-0.045,0.045,-0.045,-0.027 -o /tmp/m2.h5 --json --no-checkpoint
#
# The machine is shared: compare CPU time (user + sys), not wall time.
set -eu
exe=$1 prefix=$2
shift 2
/usr/bin/time -v -o "$prefix.time" "$exe" "$@" > "$prefix.json" 2> "$prefix.err" &
timer=$!
sleep 1
pid=$(pgrep -P "$timer" | head -n 1)
t0=$(date +%s)
: > "$prefix.rss"
while kill -0 "$pid" 2> /dev/null; do
  rss=$(awk '/VmRSS/ {print $2}' "/proc/$pid/status" 2> /dev/null || true)
  [ -n "$rss" ] && echo "$(($(date +%s) - t0)) $rss" >> "$prefix.rss"
  sleep 3
done
wait "$timer" || true
printf '| positions solved | elapsed | RSS (GiB) | largest RSS so far (GiB) |\n|---:|---:|---:|---:|\n'
tr '\r' '\n' < "$prefix.err" | sed -n 's/.* \([0-9]*\)\/[0-9]* ([0-9]* %).*elapsed \([0-9:]*\).*/\1 \2/p' | uniq |
  awk -v rss="$prefix.rss" '
    BEGIN { while ((getline line < rss) > 0) { split(line, f, " "); n++; t[n] = f[1]; r[n] = f[2] } }
    { if ($1 in seen) next; seen[$1] = 1
      k = split($2, p, ":"); s = 0; for (i = 1; i <= k; i++) s = s * 60 + p[i]
      now = 0; top = 0
      for (i = 1; i <= n && t[i] <= s + 2; i++) { now = r[i]; if (r[i] > top) top = r[i] }
      printf "| %d | %s | %.2f | %.2f |\n", $1, $2, now / 1048576, top / 1048576 }'
grep -E "Maximum resident|User time|System time|Elapsed" "$prefix.time"
