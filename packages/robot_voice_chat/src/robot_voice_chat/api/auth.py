"""Operator authentication: argon2 password check and signed, expiring session tokens.

One operator account per robot (``ADMIN_USERNAME``, default ``operator``) whose password is
stored only as an argon2 hash (``ADMIN_PASSWORD_HASH``, made by ``robot-voice-chat
hash-password``). A session is an itsdangerous-signed token (``ADMIN_SECRET_KEY``) carrying
the operator's name and a session id; logout revokes the id until the token would expire.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError
from itsdangerous import BadSignature, URLSafeTimedSerializer
from pydantic import SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict

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


@dataclass
class OperatorAuth:
    """Checks credentials and issues/reads session tokens. Built once by the composition root."""

    config: AuthConfig
    username: str
    password_hash: str
    secret_key: str
    clock: Callable[[], float] = time.time
    _revoked: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._hasher = PasswordHasher()
        self._serializer = URLSafeTimedSerializer(self.secret_key, salt=_SALT)

    @classmethod
    def from_env(cls, config: AuthConfig, secrets_: AdminSecrets | None = None) -> OperatorAuth:
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
        return cls(config, env.username, stored, env.secret_key.get_secret_value())

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
        return self._serializer.dumps({"op": self.username, "sid": secrets.token_urlsafe(12)})

    def operator_for(self, token: str | None) -> str | None:
        """The operator's name if ``token`` is a valid, unexpired, unrevoked session."""
        payload = self._payload(token)
        return None if payload is None else payload[0]

    def revoke(self, token: str | None) -> None:
        payload = self._payload(token)
        if payload is None:
            return
        now = self.clock()
        self._revoked = {sid: exp for sid, exp in self._revoked.items() if exp > now}
        self._revoked[payload[1]] = now + self.config.session_ttl_s

    def _payload(self, token: str | None) -> tuple[str, str] | None:
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
        operator, sid = data.get("op"), data.get("sid")
        if not isinstance(operator, str) or not isinstance(sid, str) or sid in self._revoked:
            return None
        return operator, sid
