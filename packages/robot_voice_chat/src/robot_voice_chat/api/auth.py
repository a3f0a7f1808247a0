"""Operator authentication: argon2 password check and signed, expiring session tokens.

One operator account per robot (``ADMIN_USERNAME``, default ``operator``) whose password is
stored only as an argon2 hash (``ADMIN_PASSWORD_HASH``, made by ``robot-voice-chat
hash-password``). A session is an itsdangerous-signed token (``ADMIN_SECRET_KEY``) carrying
the operator's name, a session id and a fingerprint of the password hash. Logout revokes the
id until the token would expire (kept on disk: a restart does not revive it); a new password
hash changes the fingerprint, so every session issued before a password change is refused.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError
from itsdangerous import BadSignature, URLSafeTimedSerializer
from pydantic import SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict

from robot_voice_chat.api.auth_revocations import RevocationFileError, RevocationStore
from robot_voice_chat.settings import AuthConfig

_SALT = "robot-voice-chat.operator-session"
MIN_SECRET_KEY_CHARS = 32


class AuthSetupError(ValueError):
    """Auth is enabled but its secrets are missing or unusable (start-up refuses)."""


class AdminSecrets(BaseSettings):
    """``ADMIN_USERNAME``, ``ADMIN_PASSWORD_HASH``, ``ADMIN_SECRET_KEY`` from the environment."""

    model_config = SettingsConfigDict(env_prefix="ADMIN_", extra="ignore")

    username: str = "operator"
    password_hash: SecretStr | None = None
    secret_key: SecretStr | None = None


def hash_password(password: str) -> str:
    """The argon2id hash to put in ``ADMIN_PASSWORD_HASH``."""
    if not password:
        raise ValueError("the password must not be empty")
    return PasswordHasher().hash(password)


@dataclass(frozen=True)
class Session:
    """A valid session read from a token."""

    operator: str
    session_id: str
    expires_at: float  # epoch seconds


@dataclass
class OperatorAuth:
    """Checks credentials and issues/reads session tokens. Built once by the composition root."""

    config: AuthConfig
    username: str
    password_hash: str
    secret_key: str
    clock: Callable[[], float] = time.time
    revoked: RevocationStore = field(default_factory=RevocationStore)

    def __post_init__(self) -> None:
        self._hasher = PasswordHasher()
        self._serializer = URLSafeTimedSerializer(self.secret_key, salt=_SALT)
        # changes with the password hash: sessions from before a password change stop working
        self._password_mark = hmac.new(
            self.secret_key.encode(), self.password_hash.encode(), hashlib.sha256
        ).hexdigest()[:16]

    @classmethod
    def from_env(
        cls,
        config: AuthConfig,
        secrets_: AdminSecrets | None = None,
        revocations: Path | None = None,
    ) -> OperatorAuth:
        """``revocations``: the file that keeps logouts across restarts (None: memory only)."""
        env = secrets_ or AdminSecrets()
        if not env.username.strip():
            raise AuthSetupError("ADMIN_USERNAME is empty (leave it unset for 'operator')")
        if env.password_hash is None or not env.password_hash.get_secret_value().strip():
            raise AuthSetupError(
                "auth is enabled but ADMIN_PASSWORD_HASH is empty "
                "(make one with `robot-voice-chat hash-password`)"
            )
        if env.secret_key is None or len(env.secret_key.get_secret_value()) < MIN_SECRET_KEY_CHARS:
            raise AuthSetupError(
                f"auth is enabled but ADMIN_SECRET_KEY is missing or shorter than "
                f"{MIN_SECRET_KEY_CHARS} characters"
            )
        stored = env.password_hash.get_secret_value().strip()
        if not stored.startswith("$argon2"):
            raise AuthSetupError("ADMIN_PASSWORD_HASH is not an argon2 hash")
        try:
            store = RevocationStore(revocations)
        except RevocationFileError as exc:
            raise AuthSetupError(str(exc)) from exc
        return cls(config, env.username, stored, env.secret_key.get_secret_value(), revoked=store)

    def check_password(self, username: str, password: str) -> bool:
        """Constant-time on the username; argon2 verify on the password (CPU-bound: ~50 ms)."""
        name_ok = secrets.compare_digest(username.encode(), self.username.encode())
        try:
            password_ok: bool = self._hasher.verify(self.password_hash, password)
        except (VerifyMismatchError, VerificationError, InvalidHashError):
            password_ok = False
        return name_ok and password_ok

    def issue(self) -> str:
        """A signed session token for the operator."""
        return self._serializer.dumps(
            {"op": self.username, "sid": secrets.token_urlsafe(12), "pw": self._password_mark}
        )

    def operator_for(self, token: str | None) -> str | None:
        """The operator's name if ``token`` is a valid, unexpired, unrevoked session."""
        session = self.session(token)
        return None if session is None else session.operator

    def revoke(self, token: str | None) -> Session | None:
        """Refuse ``token``'s session from now on (also after a restart); the revoked session."""
        session = self.session(token)
        if session is not None:
            self.revoked.add(session.session_id, session.expires_at, self.clock())
        return session

    def session(self, token: str | None) -> Session | None:
        """The session ``token`` carries if it is valid, unexpired and unrevoked."""
        if not token:
            return None
        try:
            data, signed_at = self._serializer.loads(token, return_timestamp=True)
        except BadSignature:  # includes SignatureExpired
            return None
        age = self.clock() - signed_at.timestamp()
        if age > self.config.session_ttl_s or age < -60:
            return None
        if not isinstance(data, dict):
            return None
        operator, sid, mark = data.get("op"), data.get("sid"), data.get("pw")
        if not isinstance(operator, str) or not isinstance(sid, str) or sid in self.revoked:
            return None
        if not isinstance(mark, str) or not secrets.compare_digest(mark, self._password_mark):
            return None  # issued before the password changed
        return Session(operator, sid, signed_at.timestamp() + self.config.session_ttl_s)
