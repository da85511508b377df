"""``gidabot dashboard-passwd DIR USER [--role staff|admin] [--delete]``: the staff dashboard's users.

``DIR`` is the robot's dashboard directory (the node's ``~state_dir``, launch argument ``dashboard_dir``; by default
``$ROS_HOME/gidabot/<robot>/dashboard``), where ``users.json`` is written (mode 0600, replaced atomically; salted
scrypt hashes: :mod:`gidabot_web.web.auth`). The password is asked twice on the terminal, or read from the first
line of standard input with ``--password-stdin`` (scripts; never on the command line). A running dashboard
reads the file again at the next login.
"""

from __future__ import annotations

import argparse
import getpass
import sys
from pathlib import Path

from gidabot_web.errors import PasswordFileError
from gidabot_web.web.auth import MIN_PASSWORD, ROLES, STAFF, check_user_name, load_users, make_user, save_users

USERS_FILE = "users.json"


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gidabot dashboard-passwd", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dir", type=Path, help="the robot's dashboard directory (its users.json)")
    p.add_argument("user", help="user name: 1-64 ASCII letters, digits, '_', '.', '@', '-'")
    p.add_argument("--role", choices=ROLES, default=STAFF, help="staff (default) or admin (may also edit tours)")
    p.add_argument("--delete", action="store_true", help="remove the user")
    p.add_argument("--password-stdin", action="store_true", help="read the password from the first line of stdin")
    return p.parse_args(argv)


def read_password(from_stdin: bool) -> str:
    if from_stdin:
        return sys.stdin.readline().rstrip("\r\n")
    first = getpass.getpass(f"password (at least {MIN_PASSWORD} characters): ")
    if getpass.getpass("again: ") != first:
        raise PasswordFileError("the two passwords differ")
    return first


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    path = args.dir / USERS_FILE
    try:
        check_user_name(args.user)
        users = load_users(path) if path.exists() else {}
        if args.delete:
            if users.pop(args.user, None) is None:
                raise PasswordFileError(f"{path}: no user {args.user!r}")
            save_users(path, users)
            print(f"{path}: user {args.user} removed")
            return 0
        users[args.user] = make_user(args.user, read_password(args.password_stdin), args.role)
        save_users(path, users)
    except (PasswordFileError, OSError) as err:
        print(f"gidabot dashboard-passwd: {err}", file=sys.stderr)
        return 1
    print(f"{path}: user {args.user} ({args.role}) set")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
