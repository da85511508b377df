"""The interface vocabulary: its constants agree with the .msg files and the relays' whitelist, and neither a
``/gidabot/`` topic name nor a phase, command or robot state is spelled anywhere but in
gidabot_navigation/interface.py (with a test of each check)."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterable
from pathlib import Path

from gidabot_navigation import interface
from gidabot_navigation.interface import Cmd, Phase, RobotState
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
    phases = constants("NavEvent.msg")
    assert {name: int(value) for name, value in phases.items()} == {p.name: int(p) for p in Phase}
    assert set(interface.PHASE_NAMES) == set(Phase)
    commands = constants("VisitorCommand.msg")
    assert {name: int(value) for name, value in commands.items()} == {c.name: int(c) for c in Cmd}
    assert set(interface.COMMAND_NAMES) == set(Cmd)
    assert set(interface.REASONS) == set(constants("Cancel.msg").values())
    states = constants("RobotStatus.msg")
    assert {name: value for name, value in states.items()} == {f"STATE_{s.name}": s.value for s in RobotState}
    goal = constants("Goal.msg")
    assert (goal["WAY_LIFT"], goal["WAY_STAIRS"]) == (interface.WAY_LIFT, interface.WAY_STAIRS)
    assert [int(goal[k]) for k in ("LEG_NONE", "LEG_PROPOSED", "LEG_COMMITTED")] == list(interface.LEG_STATES)
    staff = constants("StaffCommand.msg")
    assert {k: int(v) for k, v in staff.items()} == {c.name: int(c) for c in interface.StaffCmd}
    assert set(interface.STAFF_COMMAND_NAMES) == set(interface.StaffCmd)


def test_the_visitor_sights_match_the_message() -> None:
    assert {k: int(v) for k, v in constants("VisitorTrack.msg").items()} == {s.name: int(s) for s in interface.Sight}


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


# -- the check: phases, commands and robot states only through Phase, Cmd and RobotState -------------
SPELLED = {p.name: "Phase" for p in Phase} | {c.name: "Cmd" for c in Cmd}
ROBOT_STATES = {s.value for s in RobotState}
NUMBERS = {"phase": {int(p) for p in Phase}, "command": {int(c) for c in Cmd}, "cmd": {int(c) for c in Cmd}}


def _role(node: ast.AST) -> str:
    """``phase``, ``command``, ``cmd`` or ``state`` when ``node`` names one (``phase``, ``ev.phase``,
    ``m["state"]``, ``m.get("state")``), else ""."""
    if isinstance(node, ast.Name):
        name = node.id
    elif isinstance(node, ast.Attribute):
        name = node.attr
    elif isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
        name = node.slice.value
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get" \
            and node.args and isinstance(node.args[0], ast.Constant):
        name = node.args[0].value
    else:
        return ""
    return name if name in (*NUMBERS, "state") else ""


def _meant(role: str, node: ast.AST) -> list[object]:
    """The literals of ``node`` (itself, or the items of a literal tuple, list or set) that spell a value
    of ``role`` a constant exists for (an int that is no phase, e.g. a test's hostile 99, is not one)."""
    items = node.elts if isinstance(node, (ast.Tuple, ast.List, ast.Set)) else [node]
    values = [e.value for e in items if isinstance(e, ast.Constant) and not isinstance(e.value, bool)]
    if role == "state":
        return [v for v in values if isinstance(v, str) and v in ROBOT_STATES]
    return [v for v in values if isinstance(v, int) and v in NUMBERS.get(role, ())]


def vocabulary_literals(path: Path) -> list[str]:
    """``file:line: what`` of every literal of a Python file that spells a phase, command or robot state:
    a phase or command name as a string (``"GOAL_REACHED"``; docstrings may name them) or as a name defined
    again (``GOAL_REACHED = 2``), a known phase or
    command number compared with, assigned or passed as a ``phase`` / ``command`` (``ev.phase == 2``,
    ``phase=12``), a robot state string compared with, assigned or passed as a ``state``, and two or more
    robot states in one literal dict, tuple, list or set (a table keyed by state)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    skip = _docstrings(tree)
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            skip.update(id(v) for v in node.values)
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip \
                and node.value in SPELLED:
            found.append((node.lineno, f"{node.value!r}: use {SPELLED[node.value]}.{node.value}"))
        elif isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            for role in sorted({_role(s) for s in sides} - {""}):
                found += [(node.lineno, f"{role} compared with {v!r}") for s in sides for v in _meant(role, s)]
        elif isinstance(node, ast.keyword) and node.arg:
            role = _role(ast.Name(node.arg))
            found += [(node.value.lineno, f"{node.arg}={v!r}") for v in _meant(role, node.value)] if role else []
        elif isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names = target.elts if isinstance(target, ast.Tuple) else [target]
                found += [(node.lineno, f"{n.id} defined again: use {SPELLED[n.id]}.{n.id}") for n in names
                          if isinstance(n, ast.Name) and n.id in SPELLED]
                pairs = zip(target.elts, node.value.elts, strict=False) \
                    if isinstance(target, ast.Tuple) and isinstance(node.value, ast.Tuple) else [(target, node.value)]
                for t, value in pairs:
                    role = _role(t)
                    found += [(value.lineno, f"{role} set to {v!r}") for v in _meant(role, value)] if role else []
        if isinstance(node, (ast.Dict, ast.Tuple, ast.List, ast.Set)):
            items = node.keys if isinstance(node, ast.Dict) else node.elts
            states = [e.value for e in items if isinstance(e, ast.Constant) and isinstance(e.value, str)
                      and e.value in ROBOT_STATES]
            if len(states) >= 2:
                found.append((node.lineno, f"robot states {states}: use RobotState"))
    return [f"{path}:{line}: {what}" for line, what in sorted(found)]


def test_no_phase_command_or_robot_state_literal_outside_the_interface_module() -> None:
    files = python_files([REPO / "src"])
    found = [hit for f in files for hit in vocabulary_literals(f)]
    assert not found, ("phases, commands and robot states are spelled only in gidabot_navigation/interface.py "
                       "(import Phase, Cmd, RobotState from there):\n" + "\n".join(found))


def test_the_check_finds_planted_phases_commands_and_states(tmp_path: Path) -> None:
    planted = tmp_path / "node.py"
    planted.write_text('"""Shows GOAL_REACHED pop-ups; a status whose state is "idle" is ready."""\n'
                       'ICONS = {"GOAL_REACHED": "flag"}\n'
                       'REQUEST, SKIP = 0, 4\n'
                       'COLORS = {"idle": "green", "guiding": "blue"}\n'
                       'def handle(ev, cmd, status, kw):\n'
                       '    if ev.phase == 2 or ev.phase in (12, 99) or cmd.command == 1:\n'
                       '        return f"phase {ev.phase}: GOAL_REACHED"\n'
                       '    ev.phase, ev.robot = 5, "Kbot"\n'
                       '    send(phase=13, state="waiting", command=42, tone="error")\n'
                       '    return status.state == "idle" or status.get("state") in ("error",) or kw["state"] != "x"\n',
                       encoding="utf-8")
    hits = [h.split(": ", 1)[1] for h in vocabulary_literals(planted)]
    assert sorted(hits) == sorted([
        "'GOAL_REACHED': use Phase.GOAL_REACHED", "REQUEST defined again: use Cmd.REQUEST",
        "SKIP defined again: use Cmd.SKIP", "robot states ['idle', 'guiding']: use RobotState",
        "command compared with 1", "phase compared with 2", "phase compared with 12", "phase set to 5", "phase=13",
        "state='waiting'", "state compared with 'idle'", "state compared with 'error'"])
