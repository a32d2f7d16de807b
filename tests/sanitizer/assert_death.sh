#!/bin/sh
# The test assert_macro: runs assert_death (assert_death.cpp) and checks what PVDF_ASSERT did.
#   assert_death.sh EXECUTABLE SOURCE on|off
# on:  the run must end by SIGABRT (shell status 134) with the line
#      [PATH/]assert_death.cpp:LINE: internal invariant broken: `(++evaluated, n_values == 4)`: sizes differ: 3 values for 4 nodes
#      on stderr, LINE that of the broken assertion in SOURCE, and without returning from main;
# off: the run must return 0 without evaluating either condition.
exe=${1:?usage: assert_death.sh EXECUTABLE SOURCE on|off} source=${2:?} mode=${3:?}
out=$("$exe" 2>&1)
status=$?
echo "$out"
echo "exit status $status"
if [ "$mode" = on ]; then
  line=$(grep -n 'sizes differ' "$source" | cut -d: -f1)
  # The file as the compiler named it: absolute, or relative where ccache's base_dir rewrote it.
  expected="$(basename "$source"):$line: internal invariant broken: \`(++evaluated, n_values == 4)\`: sizes differ: 3 values for 4 nodes"
  [ "$status" = 134 ] || { echo "FAIL: expected an abort (status 134)"; exit 1; }
  found=0
  while IFS= read -r l; do
    case $l in *"/$expected" | "$expected") found=1 ;; esac
  done <<EOF
$out
EOF
  [ "$found" = 1 ] || { echo "FAIL: expected a line ending in: $expected"; exit 1; }
  case $out in *returned*) echo "FAIL: main returned after a broken assertion"; exit 1 ;; esac
else
  [ "$status" = 0 ] || { echo "FAIL: expected exit status 0 with assertions off"; exit 1; }
  printf '%s\n' "$out" | grep -qxF "returned; conditions evaluated: 0" ||
    { echo "FAIL: with assertions off no condition may be evaluated"; exit 1; }
fi
echo "PVDF_ASSERT behaves as assertions $mode"
