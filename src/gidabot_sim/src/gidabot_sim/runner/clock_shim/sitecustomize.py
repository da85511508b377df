"""Imported by Python at start-up in the processes of a simulated machine whose clock is off.

``GIDABOT_CLOCK_OFFSET`` (seconds, may be negative) is added to ``time.time()`` and
``time.time_ns()``: the wall clock (rospy's wall time, log stamps, tour versions, anything
stamped with wall time) is off by that much, as on a robot whose clock is not synchronised.
The monotonic clock, sleeps and timeouts are untouched. Without the variable (or 0), nothing
changes. Every node of a robot is a Python process, so this covers the whole robot.

(libfaketime, the usual tool, cannot be used: with Python 3.11 ``time.sleep`` fails with EINVAL
when the monotonic clock is left alone, wolfcw/libfaketime#426, and hangs when it is not.)
"""

import os
import time

try:
    _offset = float(os.environ.get("GIDABOT_CLOCK_OFFSET", "0") or 0)
except ValueError:
    _offset = 0.0
if _offset:
    _time, _time_ns, _offset_ns = time.time, time.time_ns, int(round(_offset * 1e9))

    def _offset_time() -> float:
        return _time() + _offset

    def _offset_time_ns() -> int:
        return _time_ns() + _offset_ns

    time.time = _offset_time
    time.time_ns = _offset_time_ns
