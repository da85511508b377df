"""``gidabot admin-passwd [--password-stdin]``: the touch screen's administrator password, as a salted hash.

Prints the record (``scrypt:<n>:<r>:<p>:<salt hex>:<hash hex>``, :mod:`gidabot_navigation.passwords`) to pass
as ``admin_password_hash:=...`` to ``launch/gui.launch`` or ``launch/robot.launch``. The password is asked twice
on the terminal, or read from the first line of standard input with ``--password-stdin`` (scripts; never on the
command line). Every run salts anew: two records of one password differ, and both are right.
"""

from __future__ import annotations

import argparse
import getpass
import sys

from gidabot_gui.core.admin import MAX_PASSWORD
from gidabot_navigation.passwords import hash_record

MIN_PASSWORD = 8          # characters


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="gidabot admin-passwd", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--password-stdin", action="store_true", help="read the password from the first line of stdin")
    args = p.parse_args(argv)
    if args.password_stdin:
        password = sys.stdin.readline().rstrip("\r\n")
    else:
        password = getpass.getpass(f"admin password ({MIN_PASSWORD} to {MAX_PASSWORD} characters): ")
        if getpass.getpass("again: ") != password:
            print("gidabot admin-passwd: the two passwords differ", file=sys.stderr)
            return 1
    if not MIN_PASSWORD <= len(password) <= MAX_PASSWORD:
        print(f"gidabot admin-passwd: the password must have {MIN_PASSWORD} to {MAX_PASSWORD} characters",
              file=sys.stderr)
        return 1
    print(hash_record(password))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
