"""``robot-voice-chat hash-password``: print the argon2 hash for ``ADMIN_PASSWORD_HASH``."""

from __future__ import annotations

import argparse
import getpass
import sys

from robot_voice_chat.api.auth import hash_password


def hash_password_command(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="robot-voice-chat hash-password",
        description="Read the operator password (twice on a terminal, once from a pipe) "
        "and print its argon2 hash for ADMIN_PASSWORD_HASH.",
    )
    parser.add_argument("--stdin", action="store_true", help="read one line from stdin")
    args = parser.parse_args(argv)
    if args.stdin or not sys.stdin.isatty():
        password = sys.stdin.readline().rstrip("\r\n")
    else:
        password = getpass.getpass("Operator password: ")
        if getpass.getpass("Repeat: ") != password:
            sys.stderr.write("error: the passwords differ\n")
            return 2
    if len(password) < 8:
        sys.stderr.write("error: use at least 8 characters\n")
        return 2
    sys.stdout.write(hash_password(password) + "\n")
    return 0
