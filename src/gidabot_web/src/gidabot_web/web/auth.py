"""Users, passwords and sessions of the web stack (ROS-free, aiohttp-free).

- **Passwords** live in one JSON file (:class:`PasswordFile`), written only by the command
  ``gidabot dashboard-passwd`` (:mod:`gidabot_web.dashboard.passwd`), replaced atomically, mode 0600. Each user
  has a role (:data:`ROLES`: ``staff``, or ``admin``, which may do everything staff may) and a salted hash
  (:mod:`gidabot_navigation.passwords`: scrypt, a random 16-byte salt per user). Verification compares
  in constant time, and an unknown user costs the same scrypt as a known one.
- **Sessions** (:class:`Sessions`) are kept in memory: a random 256-bit id (the cookie) and a random CSRF
  token per session, an idle timeout and a bound on their number. A session is made only by a successful
  login (a new id each time: no fixation); logging out or restarting the server ends it.
- **Before login** the page has no session, only a random *pre-session* cookie; the CSRF token of the login
  form is an HMAC of it under a per-process secret (:meth:`Sessions.pre_token`), so no state is kept for
  visitors who never log in.
- **Failed logins** are limited per address (:class:`LoginLimiter`): after ``max_failures`` failures within
  ``window`` s the address is locked out for ``lockout`` s, whatever it sends, a right password included.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import re
import secrets
import tempfile
import time
from collections import OrderedDict, deque
from dataclasses import dataclass
from pathlib import Path

from gidabot_navigation.errors import PasswordHashError
from gidabot_navigation.passwords import HASH_BYTES, MAX_PASSWORD, SALT_BYTES, SCRYPT, check_cost, scrypt
from gidabot_web.errors import PasswordFileError

STAFF, ADMIN = "staff", "admin"
ROLES = (STAFF, ADMIN)
FORMAT = "gidabot-web-users/1"
USER_RE = re.compile(r"^[A-Za-z0-9_.@-]{1,64}\Z")
MIN_PASSWORD = 10              # characters
MAX_FILE_BYTES = 1024 * 1024


def allows(role: str, needed: str) -> bool:
    """Whether a user of ``role`` may do what needs ``needed`` (admin may do everything staff may)."""
    return role == ADMIN or (role == needed == STAFF)


def check_user_name(user: object) -> str:
    if not isinstance(user, str) or not USER_RE.match(user):
        raise PasswordFileError(f"user name {user!r}: expected 1-64 ASCII letters, digits, '_', '.', '@' or '-'")
    return user


@dataclass(frozen=True)
class User:
    name: str
    role: str
    salt: bytes
    hash: bytes
    n: int = SCRYPT["n"]
    r: int = SCRYPT["r"]
    p: int = SCRYPT["p"]

    def to_json(self) -> dict[str, object]:
        return {"role": self.role, "kdf": "scrypt", "n": self.n, "r": self.r, "p": self.p, "salt": self.salt.hex(),
                "hash": self.hash.hex()}


def make_user(name: str, password: str, role: str) -> User:
    """A user with a fresh salt and the scrypt hash of ``password`` (at least :data:`MIN_PASSWORD` characters)."""
    check_user_name(name)
    if role not in ROLES:
        raise PasswordFileError(f"role {role!r}: expected one of {', '.join(ROLES)}")
    if not isinstance(password, str) or not MIN_PASSWORD <= len(password) <= MAX_PASSWORD:
        raise PasswordFileError(f"the password must have {MIN_PASSWORD} to {MAX_PASSWORD} characters")
    salt = secrets.token_bytes(SALT_BYTES)
    return User(name, role, salt, scrypt(password, salt, **SCRYPT))


class PasswordFile:
    """The users of a server: ``path`` (JSON); re-read when it changed on disk (a password set while the
    server runs counts at the next login)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._users: dict[str, User] = {}
        self._stamp: tuple[int, int] | None = None
        self._dummy = User("", STAFF, b"\0" * SALT_BYTES, b"\0" * HASH_BYTES)

    def users(self) -> dict[str, User]:
        """The users now (the file re-read if it changed; {} when there is none)."""
        try:
            st = self.path.stat()
        except FileNotFoundError:
            self._users, self._stamp = {}, None
            return {}
        except OSError as err:
            raise PasswordFileError(f"{self.path}: {err.strerror}") from err
        stamp = (st.st_mtime_ns, st.st_size)
        if stamp != self._stamp:
            self._users = load_users(self.path)
            self._stamp = stamp
        return dict(self._users)

    def verify(self, name: object, password: object) -> User | None:
        """The user, when ``password`` is right; else None (same cost for an unknown user)."""
        users = self.users()
        user = users.get(name) if isinstance(name, str) else None
        candidate = user or self._dummy
        text = password if isinstance(password, str) and len(password) <= MAX_PASSWORD else ""
        digest = scrypt(text, candidate.salt, candidate.n, candidate.r, candidate.p)
        ok = hmac.compare_digest(digest, candidate.hash)
        return user if ok and user is not None and text else None


def load_users(path: Path) -> dict[str, User]:
    """Every user of a password file; PasswordFileError naming the file and the bad entry."""
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise PasswordFileError(f"{path}: {err.strerror}") from err
    if len(raw) > MAX_FILE_BYTES:
        raise PasswordFileError(f"{path}: {len(raw)} bytes; at most {MAX_FILE_BYTES} expected")
    try:
        doc = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise PasswordFileError(f"{path}: not a JSON password file: {err}") from err
    if not isinstance(doc, dict) or doc.get("format") != FORMAT or not isinstance(doc.get("users"), dict):
        raise PasswordFileError(f"{path}: expected {{'format': {FORMAT!r}, 'users': {{...}}}}")
    users = {}
    for name, entry in doc["users"].items():
        try:
            check_user_name(name)
            if not isinstance(entry, dict) or entry.get("kdf") != "scrypt" or entry.get("role") not in ROLES:
                raise PasswordFileError(f"user {name!r}: expected kdf scrypt and a role in {ROLES}")
            params = {k: entry[k] for k in ("n", "r", "p")}
            try:
                check_cost(params["n"], params["r"], params["p"], f"user {name!r}")
            except PasswordHashError as err:
                raise PasswordFileError(str(err)) from err
            users[name] = User(name, entry["role"], bytes.fromhex(entry["salt"]), bytes.fromhex(entry["hash"]),
                               **params)
        except (KeyError, TypeError, ValueError) as err:
            raise PasswordFileError(f"{path}: user {name!r}: {err!r}") from err
        except PasswordFileError as err:
            raise PasswordFileError(f"{path}: {err}") from err
    return users


def save_users(path: Path, users: dict[str, User]) -> None:
    """Write the password file atomically (temporary file in the same directory, fsync, rename), mode 0600."""
    doc = {"format": FORMAT, "users": {name: u.to_json() for name, u in sorted(users.items())}}
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".users.", dir=path.parent)
    try:
        os.fchmod(fd, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            json.dump(doc, out, indent=1)
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@dataclass
class Session:
    id: str
    user: str
    role: str
    csrf: str
    created: float
    seen: float


class Sessions:
    """Logged-in sessions, in memory (see the module docstring)."""

    def __init__(self, idle_timeout: float = 8 * 3600.0, max_sessions: int = 1000,
                 clock: object = time.monotonic) -> None:
        self.idle_timeout = idle_timeout
        self.max_sessions = max_sessions
        self.clock = clock
        self._secret = secrets.token_bytes(32)
        self._sessions: OrderedDict[str, Session] = OrderedDict()

    def create(self, user: str, role: str) -> Session:
        now = self.clock()  # type: ignore[operator]
        s = Session(secrets.token_urlsafe(32), user, role, secrets.token_urlsafe(32), now, now)
        self._sessions[s.id] = s
        while len(self._sessions) > self.max_sessions:
            self._sessions.popitem(last=False)
        return s

    def get(self, sid: object) -> Session | None:
        """The live session with id ``sid`` (its idle timer restarted), else None."""
        if not isinstance(sid, str):
            return None
        s = self._sessions.get(sid)
        if s is None:
            return None
        now = self.clock()  # type: ignore[operator]
        if now - s.seen > self.idle_timeout:
            del self._sessions[sid]
            return None
        s.seen = now
        self._sessions.move_to_end(sid)
        return s

    def end(self, sid: str) -> None:
        self._sessions.pop(sid, None)

    def end_user(self, user: str) -> None:
        for sid in [k for k, s in self._sessions.items() if s.user == user]:
            del self._sessions[sid]

    def __len__(self) -> int:
        return len(self._sessions)

    def pre_token(self, nonce: str) -> str:
        """The CSRF token of the login form for pre-session cookie ``nonce``."""
        return hmac.new(self._secret, b"pre:" + nonce.encode("utf-8", "replace"), hashlib.sha256).hexdigest()

    def check_pre_token(self, nonce: object, token: object) -> bool:
        return isinstance(nonce, str) and isinstance(token, str) and 16 <= len(nonce) <= 128 and \
            hmac.compare_digest(self.pre_token(nonce), token)


class LoginLimiter:
    """Failed logins per address: ``max_failures`` within ``window`` s lock the address out for ``lockout`` s."""

    def __init__(self, max_failures: int = 5, window: float = 60.0, lockout: float = 60.0,
                 max_addresses: int = 10000) -> None:
        self.max_failures, self.window, self.lockout = max_failures, window, lockout
        self.max_addresses = max_addresses
        self._failures: OrderedDict[str, deque[float]] = OrderedDict()
        self._locked_until: dict[str, float] = {}

    def locked(self, address: str, now: float) -> bool:
        until = self._locked_until.get(address)
        if until is None:
            return False
        if now >= until:
            del self._locked_until[address]
            self._failures.pop(address, None)
            return False
        return True

    def failed(self, address: str, now: float) -> None:
        times = self._failures.setdefault(address, deque())
        self._failures.move_to_end(address)
        times.append(now)
        while times and now - times[0] > self.window:
            times.popleft()
        if len(times) >= self.max_failures:
            self._locked_until[address] = now + self.lockout
        while len(self._failures) > self.max_addresses:
            old, _ = self._failures.popitem(last=False)
            self._locked_until.pop(old, None)

    def succeeded(self, address: str) -> None:
        self._failures.pop(address, None)
