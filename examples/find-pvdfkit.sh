# Sourced by the example scripts (POSIX sh): sets PVDFKIT to the pvdfkit to run, in this order —
#   1. $PVDFKIT, when set (any build or install);
#   2. this checkout's build, build/app/pvdfkit (what scripts/build and scripts/main-job make;
#      $PVDF_BUILD_DIR/app/pvdfkit when that is set);
#   3. pvdfkit on PATH (after `cmake --install build`, e.g. /usr/local/bin/pvdfkit).
# Exits 127 with a one-line error naming the places it looked when none exists.
pvdf_examples_dir=$(cd "$(dirname "$0")/.." && pwd)
pvdf_checkout_build=${PVDF_BUILD_DIR:-$pvdf_examples_dir/../build}
if [ -n "${PVDFKIT:-}" ]; then
  if ! [ -x "$PVDFKIT" ] && ! command -v "$PVDFKIT" >/dev/null 2>&1; then
    echo "error: PVDFKIT=$PVDFKIT is not an executable; unset it to use the built or installed pvdfkit" >&2
    exit 127
  fi
elif [ -x "$pvdf_checkout_build/app/pvdfkit" ]; then
  PVDFKIT=$(cd "$pvdf_checkout_build/app" && pwd)/pvdfkit
elif command -v pvdfkit >/dev/null 2>&1; then
  PVDFKIT=$(command -v pvdfkit)
else
  echo "error: pvdfkit not found (PVDFKIT unset, no $pvdf_checkout_build/app/pvdfkit, none on PATH);" \
       "build it with scripts/build, or install it with cmake --install build" >&2
  exit 127
fi
echo "using $PVDFKIT"
