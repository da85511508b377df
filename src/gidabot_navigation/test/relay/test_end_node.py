"""The relay end's ROS adapter without a master: its options, message checks, raw classes, configuration
and diagnostics (end_node.py)."""

from __future__ import annotations

import io

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from gidabot_msgs.msg import Goal, RobotStatus
from gidabot_navigation.errors import RelayConfigError
from gidabot_navigation.interface import RobotState, Topic, TopicSpec
from gidabot_navigation.relay.end import load_shared_topics
from gidabot_navigation.relay.end_node import (
    Params,
    _message_class,
    diagnostic_status,
    end_config,
    make_speaker,
    make_validator,
    raw_class,
)
from gidabot_navigation.resources import resource

REQUIRED = ["--robot_a", "Tartalo", "--robot_b", "Kbot", "--side", "b", "--link_host", "10.0.0.2",
            "--link_port", "11411", "--state_dir", "/tmp/relay"]


def raw(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def specs_and_classes() -> tuple[tuple[TopicSpec, ...], dict[str, type]]:
    specs = load_shared_topics(resource("config", "shared_topics.yaml"))
    return specs, {s.name: _message_class(s) for s in specs}


def test_params_defaults_and_ros_remappings_ignored() -> None:
    p = Params.parse(REQUIRED + ["__name:=ignored", "--heartbeat", "0.25", "--bind_ip", "10.0.0.1"])
    assert (p.robot_a, p.robot_b, p.side, p.link_host, p.link_port) == ("Tartalo", "Kbot", "b", "10.0.0.2", 11411)
    assert (p.heartbeat, p.link_timeout, p.state_rate, p.hold_grace, p.bind_ip) == (0.25, 2.0, 10.0, 1.5, "10.0.0.1")
    assert p.max_queue == 10000 and p.replay_limit == 500 and p.topics_file == "" and p.secret_file == ""


@pytest.mark.parametrize(("extra", "text"), [
    (["--side", "c"], "bad relay_end options"),
    (["--heartbeat", "0"], "--heartbeat must be positive"),
    (["--state_rate", "nan"], "--state_rate must be positive"),
    (["--link_port", "70000"], "is not a TCP port"),
    (["--link_host", "robot.local"], "is not an IPv4 address"),
    (["--bind_ip", "10.1"], "is not a dotted IPv4 address"),
    (["--robot_b", "K-bot"], "robot names are letters"),
    (["--replay_limit", "20000"], "--replay_limit"),
])
def test_bad_params_are_refused_with_what_is_wrong(extra: list[str], text: str) -> None:
    with pytest.raises(RelayConfigError, match=text):
        Params.parse(REQUIRED + extra)


def test_a_missing_option_is_refused() -> None:
    with pytest.raises(RelayConfigError, match="bad relay_end options"):
        Params.parse(REQUIRED[2:])                               # --robot_a missing


def test_the_validator_takes_exactly_a_well_formed_message() -> None:
    validate = make_validator({Topic.GOALS: Goal})
    data = raw(Goal(uid="Tartalo/v1/1", origin_robot="Tartalo"))
    assert validate(Topic.GOALS, data) is None
    assert "trailing bytes" in validate(Topic.GOALS, data + b"\0")
    assert "not a valid gidabot_msgs/Goal" in validate(Topic.GOALS, data[:-3])
    bad_utf8 = data.replace(b"Tartalo/v1/1", b"Tartalo/v1/\xff")
    assert validate(Topic.GOALS, bad_utf8) is not None


def test_the_speaker_is_the_robot_field_of_a_state_and_nobody_else() -> None:
    speaker = make_speaker({Topic.STATUS: RobotStatus, Topic.GOALS: Goal})
    assert speaker(Topic.STATUS, raw(RobotStatus(robot="Kbot"))) == "Kbot"
    assert speaker(Topic.STATUS, b"\x01") is None                   # undecodable: the validator says why
    assert speaker(Topic.GOALS, raw(Goal(origin_robot="Kbot"))) is None   # no robot field


def test_a_raw_class_publishes_bytes_under_the_real_type() -> None:
    cls = raw_class(RobotStatus)
    msg = cls()
    data = raw(RobotStatus(robot="Kbot", state=RobotState.IDLE))
    msg._buff = data
    assert (cls._type, cls._md5sum, cls._full_text) == (RobotStatus._type, RobotStatus._md5sum, RobotStatus._full_text)
    assert raw(msg) == data


def test_the_core_configuration_from_the_options_and_the_shared_topics(tmp_path) -> None:
    specs, classes = specs_and_classes()
    secret = tmp_path / "secret"
    secret.write_text("correct horse battery staple\n")
    cfg = end_config(Params.parse(REQUIRED + ["--secret_file", str(secret), "--max_queue", "7"]), specs, classes)
    assert (cfg.robot, cfg.peer_robot, cfg.side, cfg.max_queue) == ("Kbot", "Tartalo", "b", 7)
    assert cfg.secret == b"correct horse battery staple"
    assert cfg.md5s[Topic.GOALS] == Goal._md5sum and set(cfg.md5s) == {s.name for s in specs}
    assert Topic.GOALS in cfg.header_topics and Topic.STATUS not in cfg.header_topics   # events only
    with pytest.raises(RelayConfigError, match="unknown message type|cannot load"):
        _message_class(TopicSpec("/x", "gidabot_msgs/NoSuchType", "event"))


def test_diagnostics_say_down_held_or_ok() -> None:
    specs, classes = specs_and_classes()
    cfg = end_config(Params.parse(REQUIRED), specs, classes)
    snap = {"connected": False, "queue_depth": 3, "peer_master_up": None, "master_up": True, "delivery_open": True,
            "rtt_ms": None}
    down = diagnostic_status(cfg, snap, 2.04)
    assert (down.level, down.message) == (DiagnosticStatus.ERROR, "link to Tartalo down for 2.0 s; 3 event(s) queued")
    assert down.name == "relay Tartalo-Kbot: Kbot" and down.hardware_id == cfg.node_name
    assert {kv.key: kv.value for kv in down.values}["rtt_ms"] == ""
    held = diagnostic_status(cfg, {**snap, "connected": True, "peer_master_up": False}, None)
    assert (held.level, held.message) == (DiagnosticStatus.WARN, "connected; master of Tartalo down or restarting, "
                                                                 "events held")
    ok = diagnostic_status(cfg, {**snap, "connected": True, "peer_master_up": True, "rtt_ms": 0.5}, None)
    assert (ok.level, ok.message) == (DiagnosticStatus.OK, "connected to Tartalo, rtt 0.5 ms")
