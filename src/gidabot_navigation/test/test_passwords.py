"""Salted password hashes (passwords.py): records and their checks."""

from __future__ import annotations

import pytest

from gidabot_navigation.errors import PasswordHashError
from gidabot_navigation.passwords import parse_record, salted_hash


def test_a_record_round_trips_and_only_its_password_matches() -> None:
    h = salted_hash("correct horse")
    again = parse_record(h.record())
    assert again == h and again.matches("correct horse")
    assert not again.matches("correct hors") and not again.matches("") and not again.matches(None)
    assert not again.matches("x" * 100000)                              # overlong: refused before hashing
    assert parse_record(" " + h.record().upper() + "\n") == h           # pasted with blanks, in capitals


@pytest.mark.parametrize("bad", ["", "secret", "a" * 64, "scrypt:16384:8:1:zz:" + "0" * 64, "scrypt:16384:8:1",
                                 "bcrypt:16384:8:1:" + "0" * 32 + ":" + "0" * 64,
                                 "scrypt:16384:8:1:" + "0" * 32 + ":" + "0" * 63, None, 3.5])
def test_a_malformed_record_is_named_and_says_how_to_make_one(bad: object) -> None:
    with pytest.raises(PasswordHashError, match="admin_password_hash .*gidabot admin-passwd"):
        parse_record(bad, "admin_password_hash")


@pytest.mark.parametrize("params", ["0:8:1", "1000:8:1", "1048576:1024:1", "16384:0:1", "16384:8:0"])
def test_costs_out_of_range_are_refused_before_any_hashing(params: str) -> None:
    with pytest.raises(PasswordHashError, match="out of range"):
        parse_record(f"scrypt:{params}:{'0' * 32}:{'0' * 64}")
