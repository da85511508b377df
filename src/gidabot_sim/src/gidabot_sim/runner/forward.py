"""A TCP port on this host's loopback forwarded to a machine of the run (separate machines: the host cannot reach
the robots' network namespaces). The staff's browser on this host opens ``http://127.0.0.1:<port>/``; each
connection is carried, byte for byte, to a connection opened from inside the staff machine (the one machine each
robot's firewall admits to its dashboard), so the robots see the staff network's address, as on a real site."""

from __future__ import annotations

import contextlib
import socket
import threading
from collections.abc import Callable

BUFFER = 64 * 1024


class Forward:
    """Listens on ``host`` (a free port: :attr:`port`); ``connect()`` opens the far side of each connection."""

    def __init__(self, connect: Callable[[], socket.socket], host: str = "127.0.0.1") -> None:
        self.connect = connect
        self.server = socket.create_server((host, 0))
        self.host, self.port = host, self.server.getsockname()[1]
        self._closed = threading.Event()
        self._socks: set[socket.socket] = set()
        self._lock = threading.Lock()
        threading.Thread(target=self._accept, name=f"forward-{self.port}", daemon=True).start()

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                near, _ = self.server.accept()
            except OSError:
                return
            try:
                far = self.connect()
            except OSError:
                near.close()
                continue
            with self._lock:
                self._socks.update((near, far))
            for a, b in ((near, far), (far, near)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket) -> None:
        try:
            while data := src.recv(BUFFER):
                dst.sendall(data)
        except OSError:
            pass
        finally:
            for s in (src, dst):
                with contextlib.suppress(OSError):
                    s.shutdown(socket.SHUT_RDWR)
                with contextlib.suppress(OSError):
                    s.close()

    def close(self) -> None:
        self._closed.set()
        with contextlib.suppress(OSError):
            self.server.close()
        with self._lock:
            for s in self._socks:
                with contextlib.suppress(OSError):
                    s.close()
            self._socks.clear()
