"""The interface vocabulary: its constants agree with the .msg files and the relays' whitelist, and no
``/gidabot/`` topic name is spelled anywhere but in gidabot_navigation/interface.py (with a test of that check)."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterable
from pathlib import Path

from gidabot_navigation import interface
from gidabot_navigation.relay.end import load_shared_topics

REPO = Path(__file__).resolve().parents[3]
MSG = REPO / "src" / "gidabot_msgs" / "msg"
SHARED_TOPICS_FILE = REPO / "src" / "gidabot_navigation" / "config" / "shared_topics.yaml"
# the vocabulary itself, and this check (which must spell the pattern it looks for)
EXEMPT = {Path(interface.__file__).resolve(), Path(__file__).resolve()}
SCANNED = ("src", "tests", "tools")
HOLE = "\0"        # stands for a {replacement field} of an f-string
# a topic name: "/gidabot/" at the start of the text or after a character that cannot be part of a path
# ("$ROS_HOME/gidabot/...", "/etc/gidabot/..." and f"{home}/gidabot/..." are directories, not topics)
TOPIC_RE = re.compile(r"(?:^|[^\w$.~/" + HOLE + r"-])/gidabot/")


def constants(name: str) -> dict[str, str]:
    out = {}
    for line in (MSG / name).read_text().splitlines():
        m = re.match(r"^\s*(uint8|string)\s+([A-Z_]+)=(\S+)", line)
        if m:
            out[m.group(2)] = m.group(3)
    return out


def test_constants_match_the_messages() -> None:
    for name, value in constants("NavEvent.msg").items():
        assert getattr(interface, name) == int(value) == interface.Phase[name], name
    assert {k: int(v) for k, v in constants("NavEvent.msg").items()}.keys() >= {"PARTNER_LOST", "PARTNER_BACK"}
    assert set(interface.PHASE_NAMES) == {int(v) for v in constants("NavEvent.msg").values()}
    for name, value in constants("VisitorCommand.msg").items():
        assert getattr(interface, name) == int(value) == interface.Cmd[name], name
    assert set(interface.REASONS) == set(constants("Cancel.msg").values())
    assert set(interface.ROBOT_STATES) == set(constants("RobotStatus.msg").values())
    goal = constants("Goal.msg")
    assert (goal["WAY_LIFT"], goal["WAY_STAIRS"]) == (interface.WAY_LIFT, interface.WAY_STAIRS)
    assert [int(goal[k]) for k in ("LEG_NONE", "LEG_PROPOSED", "LEG_COMMITTED")] == list(interface.LEG_STATES)
    staff = constants("StaffCommand.msg")
    assert {k: int(v) for k, v in staff.items()} == {c.name: int(c) for c in interface.StaffCmd}
    assert set(interface.STAFF_COMMAND_NAMES) == set(interface.StaffCmd)


def test_the_relays_whitelist_of_the_package_lists_exactly_the_shared_topics() -> None:
    listed = load_shared_topics(SHARED_TOPICS_FILE)          # (name, type, class) of each
    assert sorted(listed, key=lambda t: t.name) == sorted(interface.SHARED_TOPICS, key=lambda t: t.name)
    assert {t.name for t in interface.SHARED_TOPICS if t.kind == interface.EVENT} == {
        interface.Topic.GOALS, interface.Topic.CANCELS, interface.Topic.NAV_EVENTS, interface.Topic.TOURS,
        interface.Topic.STAFF}
    # every /gidabot/ topic is shared, and only those
    assert {t.name for t in interface.SHARED_TOPICS} == {
        v for k, v in vars(interface.Topic).items() if k.isupper() and v.startswith("/gidabot/")}


# -- the check: no /gidabot/ topic literal outside interface.py ----------------------------------
def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def topic_literals(path: Path) -> list[str]:
    """``file:line: text`` of every string constant (f-string parts included, docstrings not) of a Python
    file that spells a ``/gidabot/`` topic name."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    skip = _docstrings(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            skip.update(id(v) for v in node.values)
            text = "".join(v.value if isinstance(v, ast.Constant) else HOLE for v in node.values)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            text = node.value
        else:
            continue
        if TOPIC_RE.search(text):
            found.append(f"{path}:{node.lineno}: {text.replace(HOLE, '{...}')[:80]!r}")
    return sorted(found, key=lambda f: (f.split(":")[0], int(f.split(":")[1])))


def python_files(roots: Iterable[Path]) -> list[Path]:
    return sorted(p for root in roots for p in root.rglob("*.py") if p.resolve() not in EXEMPT)


def test_no_topic_literal_outside_the_interface_module() -> None:
    files = python_files(REPO / d for d in SCANNED)
    assert len(files) > 100
    found = [hit for f in files for hit in topic_literals(f)]
    assert not found, ("/gidabot/ topic names are spelled only in gidabot_navigation/interface.py "
                       "(import Topic from there; docstrings may name them):\n" + "\n".join(found))


def test_the_check_finds_a_planted_topic_literal(tmp_path: Path) -> None:
    planted = tmp_path / "pkg" / "node.py"
    planted.parent.mkdir()
    planted.write_text('"""Publishes /gidabot/goals (a docstring may name the API)."""\n'
                       'import os\n'
                       'STATE_DIR = os.path.expandvars("$ROS_HOME/gidabot/Kbot")   # a directory\n'
                       'SECRET = "/etc/gidabot/relay.secret"\n'
                       'GOALS = "/gidabot/goals"\n'
                       'def topic(name):\n'
                       '    """The topic /gidabot/<name>."""\n'
                       '    home = "/home"\n'
                       '    return f"{home}/gidabot/{name}", f"/gidabot/{name}", ["rostopic echo /gidabot/status"]\n',
                       encoding="utf-8")
    assert python_files([tmp_path]) == [planted]
    hits = topic_literals(planted)
    assert [h.split(": ", 1)[0] for h in hits] == [f"{planted}:5", f"{planted}:9", f"{planted}:9"]
    assert "'/gidabot/{...}'" in hits[1] + hits[2] and "'rostopic echo /gidabot/status'" in hits[1] + hits[2]
