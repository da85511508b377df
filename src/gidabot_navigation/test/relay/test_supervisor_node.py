"""The relay supervisor's ROS adapter without a master: its parameters and diagnostics (supervisor_node.py)."""

from __future__ import annotations

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from gidabot_navigation.errors import RelayConfigError
from gidabot_navigation.relay.supervisor import plan_relays
from gidabot_navigation.relay.supervisor_node import Params, _describe, diagnostic_status


def getter(values: dict[str, object]):
    return lambda name, default: values.get(name, default)


def test_params_with_a_secret_and_end_options(tmp_path) -> None:
    secret = tmp_path / "secret"
    secret.write_text("0123456789abcdef0123")
    p = Params.parse(getter({"~building": "maps/faculty", "~robot": "Kbot", "~state_dir": str(tmp_path / "state"),
                             "~secret_file": str(secret), "~end_params": {"heartbeat": 0.25, "max_queue": 100}}))
    assert (p.robot, p.secret_file, p.topics_file) == ("Kbot", str(secret.resolve()), "")
    assert p.end_params == (("heartbeat", "0.25"), ("max_queue", "100"))
    opts = p.end_options()
    assert (tmp_path / "state").is_dir() and opts.state_dir == str((tmp_path / "state").resolve())
    assert opts.extra == p.end_params and opts.secret_file == p.secret_file


@pytest.mark.parametrize(("values", "text"), [
    ({"~robot": "Kbot", "~state_dir": "/tmp/s"}, "~building, ~robot and ~state_dir are required"),
    ({"~building": "b", "~robot": "Kbot", "~state_dir": "/tmp/s", "~end_params": [1]}, "~end_params must be a mapping"),
])
def test_bad_params_are_refused(values: dict, text: str) -> None:
    with pytest.raises(RelayConfigError, match=text):
        Params.parse(getter(values))


def test_a_short_secret_fails_in_the_supervisor_not_in_every_end(tmp_path) -> None:
    secret = tmp_path / "secret"
    secret.write_text("short")
    with pytest.raises(RelayConfigError, match="at least 16"):
        Params.parse(getter({"~building": "b", "~robot": "Kbot", "~state_dir": "/tmp/s", "~secret_file": str(secret)}))


def test_diagnostics_warn_while_an_end_is_not_running() -> None:
    rows = [("Tartalo_Kbot.b", 1234, 0, None, "10.0.0.2:11411"), ("Kbot_MariSorgin.a", None, 2, 1, "10.0.0.3:11412")]
    st = diagnostic_status("Kbot", rows)
    assert (st.level, st.message, st.name, st.hardware_id) == (DiagnosticStatus.WARN, "1/2 relay ends running",
                                                               "relay_supervisor: Kbot", "Kbot")
    assert [(kv.key, kv.value) for kv in st.values] == [
        ("Tartalo_Kbot.b", "pid 1234, restarts 0, last exit None, link 10.0.0.2:11411"),
        ("Kbot_MariSorgin.a", "pid -, restarts 2, last exit 1, link 10.0.0.3:11412")]
    assert diagnostic_status("Kbot", rows[:1]).level == DiagnosticStatus.OK


def test_each_end_is_described_by_whom_it_connects_to_or_listens_for(faculty) -> None:
    texts = [_describe(e) for e in plan_relays(faculty, "Kbot")]
    assert any(t.startswith("Tartalo_Kbot (listens for Tartalo on ") for t in texts)
    assert any(t.startswith("Kbot_MariSorgin (connects to MariSorgin at ") for t in texts)
