"""Salted password hashes (ROS-free, stdlib): the one key derivation of every GidaBot password.

``hashlib.scrypt`` (n 2^14, r 8, p 1, 32 bytes) with a random 16-byte salt per password. The staff dashboard's
users file keeps its fields as JSON (:mod:`gidabot_web.web.auth`); the touch screen's administrator password is one
text record, ``scrypt:<n>:<r>:<p>:<salt hex>:<hash hex>`` (:func:`hash_record`, made by ``gidabot admin-passwd``),
which can sit in a ROS parameter readable by anyone on the master without giving the password away to a lookup
table. Verification compares in constant time.
"""

from __future__ import annotations

import hashlib
import hmac
import re
import secrets
from dataclasses import dataclass

from gidabot_navigation.errors import PasswordHashError

SCRYPT = {"n": 2 ** 14, "r": 8, "p": 1}
HASH_BYTES = 32
SALT_BYTES = 16
MAX_COST = 2 ** 20            # n, r, p each at most this (a record cannot make a check take forever)
MAX_MEMORY = 64 * 1024 * 1024
MAX_PASSWORD = 1024           # characters: longer ones are refused before hashing
RECORD_KIND = "scrypt"
_RECORD_RE = re.compile(r"^scrypt:(\d{1,8}):(\d{1,8}):(\d{1,8}):([0-9a-f]{32,128}):([0-9a-f]{64})\Z")


def scrypt(password: str, salt: bytes, n: int, r: int, p: int) -> bytes:
    """The :data:`HASH_BYTES`-byte scrypt hash of ``password`` (UTF-8) under ``salt``."""
    return hashlib.scrypt(password.encode("utf-8"), salt=salt, n=n, r=r, p=p, maxmem=MAX_MEMORY, dklen=HASH_BYTES)


@dataclass(frozen=True)
class SaltedHash:
    salt: bytes
    hash: bytes
    n: int = SCRYPT["n"]
    r: int = SCRYPT["r"]
    p: int = SCRYPT["p"]

    def matches(self, password: object) -> bool:
        """Whether ``password`` hashes to this (constant-time compare; a non-string or overlong one never does,
        at the same cost)."""
        text = password if isinstance(password, str) and len(password) <= MAX_PASSWORD else ""
        ok = hmac.compare_digest(scrypt(text, self.salt, self.n, self.r, self.p), self.hash)
        return ok and bool(text)

    def record(self) -> str:
        return f"{RECORD_KIND}:{self.n}:{self.r}:{self.p}:{self.salt.hex()}:{self.hash.hex()}"


def salted_hash(password: str) -> SaltedHash:
    """A fresh salt and the scrypt hash of ``password`` under it."""
    salt = secrets.token_bytes(SALT_BYTES)
    return SaltedHash(salt, scrypt(password, salt, **SCRYPT))


def hash_record(password: str) -> str:
    """The one-line record of a fresh salted hash of ``password`` (``scrypt:n:r:p:salt:hash``)."""
    return salted_hash(password).record()


def check_cost(n: object, r: object, p: object, what: str = "password hash") -> None:
    """PasswordHashError unless (n, r, p) are scrypt parameters a check can afford: positive integers up to
    :data:`MAX_COST`, n a power of two, at most :data:`MAX_MEMORY` of memory."""
    if not all(isinstance(v, int) and not isinstance(v, bool) and 0 < v <= MAX_COST for v in (n, r, p)) \
            or n & (n - 1) or 128 * r * (n + p + 2) > MAX_MEMORY:  # type: ignore[operator]
        raise PasswordHashError(f"{what}: scrypt parameters n={n!r} r={r!r} p={p!r} out of range "
                                "(n a power of two; at most 64 MiB of memory)")


def parse_record(record: object, what: str = "password hash") -> SaltedHash:
    """The salted hash of a record; PasswordHashError naming ``what`` and saying how to make a good one."""
    text = record.strip().lower() if isinstance(record, str) else ""
    m = _RECORD_RE.match(text)
    if m is None:
        raise PasswordHashError(f"{what} {str(record)[:40]!r}...: expected a salted hash "
                                "'scrypt:<n>:<r>:<p>:<salt hex>:<hash hex>' (make one with: gidabot admin-passwd)")
    n, r, p = (int(m.group(k)) for k in (1, 2, 3))
    check_cost(n, r, p, what)
    return SaltedHash(bytes.fromhex(m.group(4)), bytes.fromhex(m.group(5)), n, r, p)
