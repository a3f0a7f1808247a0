"""Revoked session ids (logout), kept on disk so a restart does not bring them back.

One small JSON file in the brain's data dir, ``{"revoked": {session_id: expires_at}}`` with
epoch seconds; entries are dropped once the token they revoke would have expired anyway.
Every change is written to a temporary file, fsync'd and renamed over the old one (then the
directory is fsync'd), so a crash leaves either the old or the new list, never half of one.
"""

from __future__ import annotations

import json
import os
from pathlib import Path


class RevocationFileError(ValueError):
    """The revocation file exists but cannot be read (start-up refuses)."""


class RevocationStore:
    """Session ids that must stay refused until ``expires_at``. ``path=None``: memory only."""

    def __init__(self, path: Path | None = None) -> None:
        self.path = path
        self._revoked: dict[str, float] = self._load() if path is not None else {}

    def __contains__(self, session_id: object) -> bool:
        return session_id in self._revoked

    def add(self, session_id: str, expires_at: float, now: float) -> None:
        self._revoked = {sid: exp for sid, exp in self._revoked.items() if exp > now}
        self._revoked[session_id] = expires_at
        if self.path is not None:
            self._save(self.path)

    def _load(self) -> dict[str, float]:
        assert self.path is not None
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return {}
        except (OSError, ValueError) as exc:
            raise RevocationFileError(
                f"cannot read the session revocation list {self.path}: {exc}"
            ) from exc
        revoked = data.get("revoked") if isinstance(data, dict) else None
        if not isinstance(revoked, dict) or not all(
            isinstance(k, str) and isinstance(v, int | float) for k, v in revoked.items()
        ):
            raise RevocationFileError(
                f"the session revocation list {self.path} is not "
                '{"revoked": {session_id: expires_at}}'
            )
        return {k: float(v) for k, v in revoked.items()}

    def _save(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        tmp = path.with_name(path.name + ".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            json.dump({"revoked": self._revoked}, out)
            out.flush()
            os.fsync(out.fileno())
        tmp.replace(path)
        directory = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(directory)
        finally:
            os.close(directory)
