#!/bin/sh
# One home per formula: π comes from core/constants.hpp, the membrane scaling laws F^(2/3), F^(1/3)
# from core/membrane_scaling.hpp and the charge law A·(d31·N11 + d32·N22)/h from core/piezo.hpp.
# Fails, listing the lines, when a source file writes one of them again.
#   one_home.sh SOURCE_DIR
root=${1:?usage: one_home.sh SOURCE_DIR}
cd "$root" || exit 2
status=0

# check WHAT PATTERN HOME FOLDERS...: C++ lines in FOLDERS matching the extended regex PATTERN,
# outside HOME (and outside tests/fem/oracles, which is self-contained on purpose: C++17 + Eigen).
check() {
  what=$1 pattern=$2 home=$3
  shift 3
  hits=$(grep -rnE "$pattern" --include='*.cpp' --include='*.hpp' --include='*.h' --include='*.cc' "$@" 2>/dev/null |
         grep -v -e "^$home:" -e '^tests/fem/oracles/')
  if [ -n "$hits" ]; then
    echo "$what written outside $home:"
    echo "$hits"
    status=1
  fi
}

all="core mesh fem mapping restore hardware fit plot app python bench tests"
# The scaling laws and the charge law are checked in the library, app and binding sources only:
# the tests' oracles and the benches' paper formulas write their own, independently of the code.
libs="core mesh fem mapping restore hardware fit plot app python/src"

check "π" '3\.14159|\bM_PI\b|acos\(-1' core/include/pvdf/core/constants.hpp $all
# shellcheck disable=SC2086
check "membrane scaling F^(2/3) / F^(1/3)" 'pow\([^;]*[^0-9.]2(\.0*)? */ *3|cbrt\(|[^0-9.]2\.0? */ *3\.0?[^0-9]' \
      core/include/pvdf/core/membrane_scaling.hpp $libs
# shellcheck disable=SC2086
check "charge law d31·N11 + d32·N22" 'd31[A-Za-z_]* *\* *[A-Za-z_0-9.]+(\[[0-9]\])? *\+ *[A-Za-z_.]*d32' \
      core/include/pvdf/core/piezo.hpp $libs

[ $status = 0 ] && echo "one home: π, the membrane scaling laws and the charge law each in one core header"
exit $status
