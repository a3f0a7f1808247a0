"""``robot-mcp-dead-letters OUTBOX``: list the events a receiver refused as malformed.

For operators: one JSON object per line, newest first. A live poster holds its outbox file
exclusively; while the server runs, read its health instead (the count and the last refusal),
or stop it to list the letters.
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import sys
from pathlib import Path

from robot_mcp_kit.outbox import read_dead_letters


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robot-mcp-dead-letters", description=__doc__)
    parser.add_argument("outbox", type=Path, help="the server's outbox SQLite file")
    parser.add_argument("--limit", type=int, default=100, help="at most this many (newest)")
    args = parser.parse_args(argv)
    if not args.outbox.is_file():
        sys.stderr.write(f"robot-mcp-dead-letters: no outbox file at {args.outbox}\n")
        return 2
    try:
        db = sqlite3.connect(f"file:{args.outbox}?mode=ro", uri=True, timeout=1.0)
        try:
            letters = read_dead_letters(db, args.limit)
        finally:
            db.close()
    except sqlite3.DatabaseError as error:  # locked, not a database, not an outbox
        reason = "in use by a running server" if "locked" in str(error) else str(error)
        sys.stderr.write(f"robot-mcp-dead-letters: cannot read {args.outbox}: {reason}\n")
        return 2
    for letter in letters:
        sys.stdout.write(json.dumps(letter.to_dict()) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
