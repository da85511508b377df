"""Files served only by the names an application lists (ROS-free, aiohttp-free).

A request names a file; it never becomes a path. :class:`NamedFiles` maps each name the application offers
(the static files of a directory, found once at start: regular files with plain names, no symbolic links;
the blueprints a building lists) to one file, resolved at start. Serving opens that file with
``O_NOFOLLOW`` and checks it is a regular file no larger than ``max_bytes``: a name that is not listed, a
file replaced by a link or a directory since, or an oversized one is not found.
"""

from __future__ import annotations

import mimetypes
import os
import re
import stat
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]*(\.[A-Za-z0-9_-]+)*\Z")
TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
         ".css": "text/css; charset=utf-8", ".svg": "image/svg+xml", ".png": "image/png", ".jpg": "image/jpeg",
         ".jpeg": "image/jpeg", ".pgm": "image/x-portable-graymap", ".ico": "image/x-icon",
         ".json": "application/json"}


@dataclass(frozen=True)
class Served:
    body: bytes
    content_type: str


def content_type(path: Path) -> str:
    return TYPES.get(path.suffix.lower()) or mimetypes.guess_type(path.name)[0] or "application/octet-stream"


class NamedFiles:
    def __init__(self, files: Mapping[str, Path], max_bytes: int = 16 * 1024 * 1024) -> None:
        self.max_bytes = max_bytes
        self._files = {}
        for name, path in files.items():
            if not SAFE_NAME.match(name):
                raise ValueError(f"file name {name!r} is not a plain name")
            self._files[name] = Path(path).resolve()

    @classmethod
    def directory(cls, path: Path, max_bytes: int = 16 * 1024 * 1024) -> NamedFiles:
        """Every regular file of ``path`` with a plain name (symbolic links, hidden files, subdirectories left
        out)."""
        found = {}
        for entry in sorted(os.scandir(path), key=lambda e: e.name):
            if SAFE_NAME.match(entry.name) and entry.is_file(follow_symlinks=False):
                found[entry.name] = Path(entry.path)
        return cls(found, max_bytes)

    def names(self) -> list[str]:
        return sorted(self._files)

    def read(self, name: object) -> Served | None:
        """The file listed as ``name``, or None (not listed, not a regular file any more, too large)."""
        path = self._files.get(name) if isinstance(name, str) else None
        if path is None:
            return None
        try:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK)
        except OSError:
            return None
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode) or st.st_size > self.max_bytes:
                return None
            with os.fdopen(fd, "rb", closefd=False) as f:
                body = f.read(self.max_bytes + 1)
        except OSError:
            return None
        finally:
            os.close(fd)
        if len(body) > self.max_bytes:
            return None
        return Served(body, content_type(path))
