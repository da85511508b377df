"""Test networks: two sessions on one machine never get the same 127.N.0.x."""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest

from gidabot_sim.errors import ProcessError
from gidabot_sim.runner import procs

# a session whose pid-derived start is network N (os.getpid replaced before the pick)
PICK = "import os; os.getpid = lambda: {start}; from gidabot_sim.runner import procs; print(procs.test_network())"


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    monkeypatch.delenv("GIDABOT_TEST_NET", raising=False)
    monkeypatch.setenv("GIDABOT_NET_LOCK_DIR", str(tmp_path))
    monkeypatch.setattr(procs, "NET_LOCK_DIR", tmp_path)
    monkeypatch.setattr(procs, "_net_lock", None)
    yield tmp_path
    if procs._net_lock is not None:
        os.close(procs._net_lock[1])


def pick_in_child(start_net: int) -> int:
    env = {k: v for k, v in os.environ.items() if k != "GIDABOT_TEST_NET"}
    code = PICK.format(start=start_net - 20)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60, check=True)
    return int(out.stdout)


def test_a_held_network_is_never_given_to_another_session(fresh, monkeypatch) -> None:
    mine = procs.test_network()
    assert procs.test_network() == mine                       # stable for the session
    assert os.environ["GIDABOT_TEST_NET"] == str(mine)        # children inherit it
    # a second session whose pid-derived start is the same network gets the next one
    assert pick_in_child(mine) == 20 + (mine - 20 + 1) % 200


def test_a_network_with_a_bound_address_is_skipped(fresh, monkeypatch) -> None:
    monkeypatch.setattr(os, "getpid", lambda: 7)              # start at N = 27
    with socket.socket() as s:
        s.bind(("127.27.0.11", 0))
        s.listen()
        assert procs.test_network() == 28


def test_an_explicit_network_is_checked(monkeypatch) -> None:
    monkeypatch.setenv("GIDABOT_TEST_NET", "300")
    with pytest.raises(ProcessError, match="GIDABOT_TEST_NET"):
        procs.test_network()
