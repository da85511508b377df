"""Link cuts really stop loopback traffic between two addresses, and are always removed."""

from __future__ import annotations

import shutil
import socket
import threading

import pytest

from gidabot_sim.chaos.faults import LinkCuts
from gidabot_sim.runner import procs

pytestmark = pytest.mark.system


def _server(ip: str) -> tuple[socket.socket, int]:
    srv = socket.socket()
    srv.bind((ip, 0))
    srv.listen(4)

    def serve() -> None:
        while True:
            try:
                srv.accept()[0].close()
            except OSError:  # closed at the end of the test
                return

    threading.Thread(target=serve, daemon=True).start()
    return srv, srv.getsockname()[1]


def _connects(src: str, dst: str, port: int) -> bool:
    s = socket.socket()
    s.settimeout(0.5)
    try:
        s.bind((src, 0))
        s.connect((dst, port))
        return True
    except OSError:
        return False
    finally:
        s.close()


@pytest.mark.skipif(shutil.which("iptables") is None, reason="iptables not installed")
def test_cut_and_restore() -> None:
    net = procs.test_network()  # this session's own 127.N network: a concurrent run's cuts never touch it
    a, b, c = f"127.{net}.91.1", f"127.{net}.91.2", f"127.{net}.91.3"
    srv, port = _server(b)
    try:
        with LinkCuts() as cuts:
            cuts.cut(a, b)
            assert not _connects(a, b, port)
            assert _connects(c, b, port)          # other robots unaffected
            cuts.restore(a, b)
            assert _connects(a, b, port)
            cuts.cut(a, b)
        assert _connects(a, b, port)              # leaving the block restores every link
    finally:
        srv.close()
