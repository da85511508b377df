#!/usr/bin/env bash
# Run GidaBot's test suites. Usage: tools/run-tests.sh [all|lint|unit|system] [pytest args...]
#   lint    ruff on every Python file, catkin_lint on src/
#   unit    pytest of the ROS-free cores (src/*/test) and the repository's rule checks (tests/, not system:
#           core purity, package.xml dependencies), no master
#   system  pytest system tests and rostests across several masters (tests/, src/*/test/*.test)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck disable=SC1091
source tools/env.sh
what="${1:-all}"; shift || true
export QT_QPA_PLATFORM=offscreen
failed=()

run() { local name="$1"; shift; echo "=== $name: $*"; if "$@"; then echo "=== $name: passed"; else echo "=== $name: FAILED"; failed+=("$name"); fi; }

lint() {
  run ruff ruff check --no-cache .
  run catkin_lint catkin_lint -W2 --strict --ignore missing_directory src
}
unit() {
  run unit pytest_suite -q -p no:cacheprovider -m "not system" src tests "$@"
}
# pytest exits 5 when a selection holds no test: not a failure for a suite
pytest_suite() { local rc=0; pytest "$@" || rc=$?; [ "$rc" -eq 5 ] && rc=0; return "$rc"; }

system() {
  run system pytest_suite -q -p no:cacheprovider --durations=30 -m "system" tests src "$@"
  local t
  for t in src/*/test/*.test; do
    [ -e "$t" ] || continue
    run "rostest $(basename "$t")" timeout 600 rostest --text "$t"
  done
}

case "$what" in
  lint) lint ;;
  unit) unit "$@" ;;
  system) system "$@" ;;
  all) lint; unit "$@"; system "$@" ;;
  *) echo "usage: $0 [all|lint|unit|system]" >&2; exit 2 ;;
esac
if [ "${#failed[@]}" -gt 0 ]; then echo "FAILED suites: ${failed[*]}"; exit 1; fi
echo "all suites passed"
