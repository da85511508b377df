"""The ~parameter helpers every node uses: a bad value is a ParamError naming the parameter and the value."""

from __future__ import annotations

import math

import pytest
import rospy

from gidabot_navigation.errors import ParamError
from gidabot_navigation.ros.params import param_number, param_text


@pytest.fixture
def server(monkeypatch: pytest.MonkeyPatch) -> dict[str, object]:
    values: dict[str, object] = {}
    monkeypatch.setattr(rospy, "get_param", lambda name, default=None: values.get(name, default))
    monkeypatch.setattr(rospy, "resolve_name", lambda name: "/node/" + name.lstrip("~"))
    return values


def test_numbers(server) -> None:
    assert param_number("~rate", 2.0) == 2.0                       # the default
    server.update({"~rate": 5, "~zero": 0, "~low": -3.0, "~nan": math.nan, "~inf": math.inf, "~flag": True,
                   "~text": "1"})
    assert param_number("~rate", 2.0) == 5.0 and isinstance(param_number("~rate", 2.0), float)
    assert param_number("~zero", 1.0, strict=False) == 0.0
    assert param_number("~low", 0.0, -5, 5, strict=False) == -3.0
    with pytest.raises(ParamError, match=r"/node/zero must be a finite number > 0, got 0"):
        param_number("~zero", 1.0)
    with pytest.raises(ParamError, match=r"/node/rate must be a finite number > 0 and <= 4, got 5"):
        param_number("~rate", 1.0, high=4)
    with pytest.raises(ParamError, match=r"/node/low must be a finite number >= 0, got -3.0"):
        param_number("~low", 1.0, strict=False)
    for name in ("~nan", "~inf", "~flag", "~text"):
        with pytest.raises(ParamError, match=name[1:]):
            param_number(name, 1.0, -math.inf, strict=False)


def test_texts(server) -> None:
    server.update({"~robot": "Kbot", "~empty": "", "~number": 3})
    assert param_text("~robot", required=True) == "Kbot"
    assert param_text("~missing", "map") == "map" and param_text("~empty") == ""
    with pytest.raises(ParamError, match=r"/node/empty must be a non-empty string, got ''"):
        param_text("~empty", required=True)
    with pytest.raises(ParamError, match=r"/node/number must be a string, got 3"):
        param_text("~number")
