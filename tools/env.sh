# Source me: the environment every GidaBot command runs in (catkin devel space + venv first on PATH).
# shellcheck shell=bash
GIDABOT_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export GIDABOT_ROOT
if [ ! -f "$GIDABOT_ROOT/devel/setup.bash" ] || [ ! -x "$GIDABOT_ROOT/.venv/bin/python" ]; then
  echo "gidabot: the workspace is not set up; run 'make setup' in $GIDABOT_ROOT first" >&2
  return 1 2>/dev/null || exit 1
fi
# devel/setup.bash (and Debian's /etc/catkin/profile.d) do not support `set -u`
case $- in *u*) _gidabot_nounset=1; set +u ;; *) _gidabot_nounset=0 ;; esac
# shellcheck disable=SC1091
source "$GIDABOT_ROOT/devel/setup.bash"
[ "$_gidabot_nounset" = 1 ] && set -u
unset _gidabot_nounset
export PATH="$GIDABOT_ROOT/.venv/bin:$GIDABOT_ROOT/bin:$PATH"
# every node is a new Python process: compiled modules are kept (outside the source tree) instead of
# compiling ours again at each start; `time python -c "import rospy, gidabot_navigation.relay.end_node,
# gidabot_navigation.guiding.goal_manager_node"`: 0.42 s of CPU without the cache, 0.36 s with it (medians of 5)
unset PYTHONDONTWRITEBYTECODE
export PYTHONPYCACHEPREFIX="$GIDABOT_ROOT/.pycache"
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1
export ROS_HOME="${ROS_HOME:-$GIDABOT_ROOT/.ros}"
# numpy's OpenBLAS: one thread per process (its idle threads spin after each LAPACK call); launch files set it too
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
