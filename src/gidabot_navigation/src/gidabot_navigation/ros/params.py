"""Reading a node's ``~parameters`` with checks: the helpers every node of gidabot_navigation and gidabot_sim uses.

A bad value raises :class:`~gidabot_navigation.errors.ParamError` naming the resolved
parameter, its value and what was expected; the node's ``main()`` logs it and exits.
"""

from __future__ import annotations

import math

import rospy

from gidabot_navigation.errors import ParamError


def param_number(name: str, default: float, low: float = 0.0, high: float = math.inf, strict: bool = True) -> float:
    """A finite number: > ``low`` (``strict``, the default: a positive number) or >= ``low``, and <= ``high``."""
    value = rospy.get_param(name, default)
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and \
        (value > low if strict else value >= low) and value <= high
    if not ok:
        bounds = ([f"{'>' if strict else '>='} {low:g}"] if low > -math.inf else []) + \
            ([f"<= {high:g}"] if high < math.inf else [])
        what = " ".join(["a finite number", " and ".join(bounds)]).strip()
        raise ParamError(f"{rospy.resolve_name(name)} must be {what}, got {value!r}")
    return float(value)


def param_text(name: str, default: str = "", required: bool = False) -> str:
    """A string (non-empty when ``required``)."""
    value = rospy.get_param(name, default)
    if not isinstance(value, str) or (required and not value):
        what = "a non-empty string" if required else "a string"
        raise ParamError(f"{rospy.resolve_name(name)} must be {what}, got {value!r}")
    return value


def robot_params() -> tuple[str, str]:
    """``~building`` (building.yaml or its directory) and ``~robot`` (this robot's name in it), both required."""
    return param_text("~building", required=True), param_text("~robot", required=True)
