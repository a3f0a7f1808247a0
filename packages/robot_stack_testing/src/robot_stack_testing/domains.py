"""A ROS domain id no other test run on this machine holds.

Test runs started at the same time (a CI run beside a developer's suite, two benchmarks) each
pick a random domain; two that pick the same one see each other's nodes, and a stack then
rightly reports another program publishing on its lock topic (``LOCK_TOPIC_SHARED``). So a run
claims its id with an exclusive ``flock`` on a file per id under the temp directory, held until
the process ends (the kernel releases it even after ``kill -9``); an id another run holds is
skipped.
"""

from __future__ import annotations

import fcntl
import os
import random
import tempfile
from pathlib import Path

FIRST_ID, LAST_ID = 1, 100
LOCK_DIR = Path(tempfile.gettempdir()) / "robot-stack-ros-domains"

_held: dict[int, int] = {}  # domain id -> the open file descriptor holding its lock


class NoFreeDomainError(RuntimeError):
    """Every domain id in the range is held by another run on this machine."""


def claim_domain_id(lock_dir: Path = LOCK_DIR, rng: random.Random | None = None) -> int:
    """A domain id in ``FIRST_ID..LAST_ID`` that no other process on this machine holds,
    claimed for the life of this process."""
    lock_dir.mkdir(parents=True, exist_ok=True)
    ids = list(range(FIRST_ID, LAST_ID + 1))
    (rng or random.SystemRandom()).shuffle(ids)
    for domain in ids:
        fd = os.open(lock_dir / f"{domain}.lock", os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        _held[domain] = fd
        return domain
    raise NoFreeDomainError(
        f"all ROS domain ids {FIRST_ID}..{LAST_ID} are held by other test runs ({lock_dir})"
    )


def release_domain_id(domain: int) -> None:
    """Give a claimed id back before the process ends (tests of the claim itself)."""
    fd = _held.pop(domain, None)
    if fd is not None:
        os.close(fd)
