"""Crash-safe, symlink-safe file operations inside one directory (ROS-free).

:class:`SafeDir` holds an open descriptor of the directory and does every
operation relative to it (``dir_fd``), so a later rename or symlink of the
directory path cannot redirect writes elsewhere. It never follows a symlink
for a name inside the directory:

- :meth:`SafeDir.create` writes a new file without ever replacing anything:
  the data go to a fresh temporary file (``O_EXCL|O_NOFOLLOW``), which is
  flushed, fsynced and then *hard-linked* to the final name (``link`` fails if
  the name exists, whatever it is), and the directory is fsynced.
- :meth:`SafeDir.replace` replaces a file only if it is a regular file whose
  content has the expected SHA-256 (the caller's proof of ownership), by
  ``rename`` of an fsynced temporary file, then fsyncs the directory.
- :meth:`SafeDir.remove` unlinks a file only under the same condition.
- :meth:`SafeDir.write_atomic` replaces a file the caller owns by name (the
  store's own metadata), refusing anything but a regular file or nothing.

After a crash a name holds either the old or the new content, never a mix;
stale temporary files (``.gidabot-tmp-*``) are removed by :meth:`SafeDir.clean_temps`.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import secrets
import stat
from dataclasses import dataclass

from gidabot_navigation.errors import TourStoreError

TEMP_PREFIX = ".gidabot-tmp-"


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@dataclass(frozen=True)
class Entry:
    """What a name in the directory is: ``kind`` is 'absent', 'file', 'symlink', 'dir' or 'other'.

    For a regular file ``sha256`` is its content hash ('' if it is larger than the read
    limit or unreadable) and ``size`` its size in bytes.
    """

    kind: str
    sha256: str = ""
    size: int = 0
    data: bytes | None = None

    @property
    def is_file(self) -> bool:
        return self.kind == "file"


class SafeDir:
    """Operations relative to an open directory descriptor; ``close()`` releases it."""

    def __init__(self, path: str | os.PathLike[str], create: bool = True) -> None:
        self.path = os.fspath(path)
        if create:
            os.makedirs(self.path, mode=0o755, exist_ok=True)
        try:
            self.fd = os.open(self.path, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        except OSError as err:
            raise TourStoreError(f"cannot open tours directory {self.path!r}: {err.strerror}") from err

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self) -> SafeDir:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- reading ------------------------------------------------------------
    def names(self) -> list[str]:
        return sorted(os.listdir(self.fd))

    def lookup(self, name: str, read_limit: int) -> Entry:
        """What ``name`` is, without following a symlink; regular files up to ``read_limit`` are read."""
        try:
            st = os.stat(name, dir_fd=self.fd, follow_symlinks=False)
        except FileNotFoundError:
            return Entry("absent")
        if stat.S_ISLNK(st.st_mode):
            return Entry("symlink")
        if stat.S_ISDIR(st.st_mode):
            return Entry("dir")
        if not stat.S_ISREG(st.st_mode):
            return Entry("other")
        if st.st_size > read_limit:
            return Entry("file", "", st.st_size)
        data = self.read(name, read_limit)
        if data is None:
            return Entry("other")
        return Entry("file", sha256(data), len(data), data)

    def read(self, name: str, limit: int) -> bytes | None:
        """Content of regular file ``name`` (at most ``limit`` + 1 bytes), or None if it is not one.

        ``O_NOFOLLOW`` refuses a symlink and ``O_NONBLOCK`` keeps a FIFO from blocking.
        """
        try:
            fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, dir_fd=self.fd)
        except OSError:
            return None
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                return None
            chunks: list[bytes] = []
            total = 0
            while total <= limit:
                chunk = os.read(fd, min(65536, limit + 1 - total))
                if not chunk:
                    break
                chunks.append(chunk)
                total += len(chunk)
            return b"".join(chunks)
        finally:
            os.close(fd)

    # -- writing ------------------------------------------------------------
    def _write_temp(self, data: bytes) -> str:
        name = f"{TEMP_PREFIX}{secrets.token_hex(8)}"
        fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644,
                     dir_fd=self.fd)
        try:
            view = memoryview(data)
            while view:
                written = os.write(fd, view)
                view = view[written:]
            os.fsync(fd)
        except BaseException:
            os.close(fd)
            with contextlib.suppress(OSError):
                os.unlink(name, dir_fd=self.fd)
            raise
        os.close(fd)
        return name

    def fsync(self) -> None:
        os.fsync(self.fd)

    def create(self, name: str, data: bytes) -> None:
        """Create ``name`` with ``data``; raise FileExistsError if anything has that name."""
        tmp = self._write_temp(data)
        try:
            os.link(tmp, name, src_dir_fd=self.fd, dst_dir_fd=self.fd, follow_symlinks=False)
        finally:
            with contextlib.suppress(OSError):
                os.unlink(tmp, dir_fd=self.fd)
        self.fsync()

    def _owned(self, name: str, expect_sha256: str, limit: int) -> None:
        entry = self.lookup(name, limit)
        if not entry.is_file or not expect_sha256 or entry.sha256 != expect_sha256:
            raise PermissionError(errno.EPERM, f"{name} is a {entry.kind} the store does not own")

    def replace(self, name: str, data: bytes, expect_sha256: str, limit: int) -> None:
        """Replace regular file ``name`` if its content hash is ``expect_sha256``, else PermissionError."""
        self._owned(name, expect_sha256, limit)
        tmp = self._write_temp(data)
        try:
            os.rename(tmp, name, src_dir_fd=self.fd, dst_dir_fd=self.fd)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp, dir_fd=self.fd)
            raise
        self.fsync()

    def remove(self, name: str, expect_sha256: str, limit: int) -> None:
        """Unlink regular file ``name`` if its content hash is ``expect_sha256``, else PermissionError."""
        self._owned(name, expect_sha256, limit)
        os.unlink(name, dir_fd=self.fd)
        self.fsync()

    def write_atomic(self, name: str, data: bytes) -> None:
        """Write ``name`` atomically (temp + fsync + rename + fsync dir); it must be a regular file or absent."""
        try:
            st = os.stat(name, dir_fd=self.fd, follow_symlinks=False)
        except FileNotFoundError:
            st = None
        if st is not None and not stat.S_ISREG(st.st_mode):
            raise PermissionError(errno.EPERM, f"{name} is not a regular file")
        tmp = self._write_temp(data)
        try:
            os.rename(tmp, name, src_dir_fd=self.fd, dst_dir_fd=self.fd)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp, dir_fd=self.fd)
            raise
        self.fsync()

    def clean_temps(self) -> list[str]:
        """Remove temporary files left by a crash (regular files named ``.gidabot-tmp-*``)."""
        removed = []
        for name in self.names():
            if name.startswith(TEMP_PREFIX) and self.lookup(name, 0).kind == "file":
                with contextlib.suppress(OSError):
                    os.unlink(name, dir_fd=self.fd)
                    removed.append(name)
        return removed
