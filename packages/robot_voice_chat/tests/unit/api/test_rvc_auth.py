"""Operator auth pieces: password hash, session tokens, throttle, the public-bind guard."""

from __future__ import annotations

import asyncio
import io
import json
import stat
import time
from pathlib import Path

import pytest
from pydantic import SecretStr

from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.api.auth import AdminSecrets, AuthSetupError, OperatorAuth, hash_password
from robot_voice_chat.api.auth_cli import hash_password_command
from robot_voice_chat.api.auth_guard import PublicBindRefusedError, ensure_bind_allowed
from robot_voice_chat.api.auth_middleware import requires_login, session_cookie
from robot_voice_chat.api.auth_throttle import (
    LoginThrottle,
    PasswordChecksBusyError,
    PasswordCheckSlots,
)
from robot_voice_chat.composition import ConfigError, build_auth, compose_config
from robot_voice_chat.main import main
from robot_voice_chat.operator import acting_operator
from robot_voice_chat.settings import AuthConfig

PASSWORD = "correct horse battery"
HASH = hash_password(PASSWORD)
KEY = "k" * 40


class Clock:
    """Starts at the wall clock (tokens are stamped with it), then moves when told."""

    def __init__(self) -> None:
        self.now = time.time()

    def __call__(self) -> float:
        return self.now


def make_auth(clock: Clock | None = None, **config: object) -> OperatorAuth:
    secrets_ = AdminSecrets(
        username="ada", password_hash=SecretStr(HASH), secret_key=SecretStr(KEY)
    )
    auth = OperatorAuth.from_env(AuthConfig(enabled=True, **config), secrets_)  # type: ignore[arg-type]
    if clock is not None:
        auth.clock = clock
    return auth


def test_password_check_accepts_only_the_right_name_and_password() -> None:
    auth = make_auth()
    assert auth.check_password("ada", PASSWORD)
    assert not auth.check_password("ada", PASSWORD + "x")
    assert not auth.check_password("bob", PASSWORD)


def test_hash_is_argon2id_and_never_the_password() -> None:
    assert HASH.startswith("$argon2id$")
    assert PASSWORD not in HASH
    with pytest.raises(ValueError, match="empty"):
        hash_password("")


def test_session_token_names_the_operator_until_it_expires() -> None:
    clock = Clock()
    auth = make_auth(clock, session_ttl_s=60)
    token = auth.issue()
    assert auth.operator_for(token) == "ada"
    clock.now += 61
    assert auth.operator_for(token) is None


def test_tampered_or_foreign_tokens_are_rejected() -> None:
    auth = make_auth()
    token = auth.issue()
    assert auth.operator_for(token[:-2] + ("AA" if token[-2:] != "AA" else "BB")) is None
    other = OperatorAuth(AuthConfig(enabled=True), "ada", HASH, "z" * 40)
    assert auth.operator_for(other.issue()) is None
    assert auth.operator_for(None) is None
    assert auth.operator_for("") is None


def test_revoked_session_is_no_longer_accepted() -> None:
    auth = make_auth()
    token, other = auth.issue(), auth.issue()
    auth.revoke(token)
    auth.revoke("garbage")
    assert auth.operator_for(token) is None
    assert auth.operator_for(other) == "ada"


@pytest.mark.parametrize(
    ("secrets_", "message"),
    [
        (AdminSecrets(secret_key=SecretStr(KEY)), "ADMIN_PASSWORD_HASH is empty"),
        (AdminSecrets(password_hash=SecretStr(HASH)), "ADMIN_SECRET_KEY"),
        (
            AdminSecrets(password_hash=SecretStr(HASH), secret_key=SecretStr("short")),
            "shorter than 32",
        ),
        (
            AdminSecrets(password_hash=SecretStr("plain"), secret_key=SecretStr(KEY)),
            "not an argon2 hash",
        ),
        (
            AdminSecrets(username=" ", password_hash=SecretStr(HASH), secret_key=SecretStr(KEY)),
            "ADMIN_USERNAME is empty",
        ),
    ],
)
def test_enabled_auth_without_usable_secrets_refuses_to_build(
    secrets_: AdminSecrets, message: str
) -> None:
    with pytest.raises(AuthSetupError, match=message):
        OperatorAuth.from_env(AuthConfig(enabled=True), secrets_)


@pytest.mark.usefixtures("mcp_credentials")
def test_robot_preset_enables_auth_and_needs_the_admin_secrets(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("ADMIN_PASSWORD_HASH", raising=False)
    monkeypatch.delenv("ADMIN_SECRET_KEY", raising=False)
    # the preset needs them too
    for name in ("NAV_EVENT_SECRET", "PERCEPTION_EVENT_SECRET", "MANIP_EVENT_SECRET"):
        monkeypatch.setenv(name, "an-event-secret-that-is-32-bytes-long")
    config = compose_config("robot")
    assert config.auth.enabled
    with pytest.raises(ConfigError, match="ADMIN_PASSWORD_HASH"):
        build_auth(config)
    monkeypatch.setenv("ADMIN_PASSWORD_HASH", HASH)
    monkeypatch.setenv("ADMIN_SECRET_KEY", KEY)
    auth = build_auth(config)
    assert auth is not None
    assert auth.username == "operator"


def test_dev_preset_runs_without_auth() -> None:
    config = compose_config("dev")
    assert not config.auth.enabled
    assert build_auth(config) is None


def test_throttle_refuses_after_max_failures_until_the_window_passes() -> None:
    clock = Clock()
    throttle = LoginThrottle(3, 60, clock)
    for _ in range(3):
        assert throttle.retry_after("10.0.0.5") == 0
        throttle.failed("10.0.0.5")
    assert throttle.retry_after("10.0.0.5") == pytest.approx(60)
    assert throttle.retry_after("10.0.0.6") == 0  # per address
    clock.now += 61
    assert throttle.retry_after("10.0.0.5") == 0


def test_a_reserved_attempt_counts_before_its_password_is_checked() -> None:
    throttle = LoginThrottle(3, 60, Clock())
    assert [throttle.reserve("10.0.0.5") for _ in range(3)] == [0, 0, 0]
    assert throttle.reserve("10.0.0.5") == pytest.approx(60)  # none of the three checked yet
    assert throttle.reserve("10.0.0.6") == 0
    throttle.succeeded("10.0.0.5")  # one of them had the right password
    assert throttle.reserve("10.0.0.5") == 0


async def test_password_checks_run_at_most_n_at_once_and_the_excess_is_refused() -> None:
    slots = PasswordCheckSlots(running=2, waiting=1)
    release = asyncio.Event()
    running = 0
    peak = 0

    async def check() -> None:
        nonlocal running, peak
        async with slots.slot():
            running += 1
            peak = max(peak, running)
            await release.wait()
            running -= 1

    tasks = [asyncio.create_task(check()) for _ in range(3)]
    await asyncio.sleep(0)
    assert slots.admitted == 3
    with pytest.raises(PasswordChecksBusyError):
        async with slots.slot():
            pass
    release.set()
    async with asyncio.timeout(5):
        await asyncio.gather(*tasks)
    assert peak == 2
    assert slots.admitted == 0
    async with slots.slot():  # free again
        assert slots.admitted == 1


def test_a_logout_is_kept_on_disk_and_refused_after_a_restart(tmp_path: Path) -> None:
    path = tmp_path / "data" / "revoked_sessions.json"
    secrets_ = AdminSecrets(
        username="ada", password_hash=SecretStr(HASH), secret_key=SecretStr(KEY)
    )
    before = OperatorAuth.from_env(AuthConfig(enabled=True), secrets_, revocations=path)
    token, kept = before.issue(), before.issue()
    assert before.revoke(token) is not None
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    after = OperatorAuth.from_env(AuthConfig(enabled=True), secrets_, revocations=path)
    assert after.operator_for(token) is None
    assert after.operator_for(kept) == "ada"


def test_an_unreadable_revocation_list_refuses_the_start(tmp_path: Path) -> None:
    path = tmp_path / "revoked_sessions.json"
    path.write_text('{"revoked": ["not", "a", "map"]}')
    secrets_ = AdminSecrets(password_hash=SecretStr(HASH), secret_key=SecretStr(KEY))
    with pytest.raises(AuthSetupError, match="revocation list"):
        OperatorAuth.from_env(AuthConfig(enabled=True), secrets_, revocations=path)
    path.write_text("{half")
    with pytest.raises(AuthSetupError, match="cannot read"):
        OperatorAuth.from_env(AuthConfig(enabled=True), secrets_, revocations=path)


def test_expired_revocations_are_dropped_from_the_file(tmp_path: Path) -> None:
    path = tmp_path / "revoked_sessions.json"
    clock = Clock()
    secrets_ = AdminSecrets(password_hash=SecretStr(HASH), secret_key=SecretStr(KEY))
    auth = OperatorAuth.from_env(AuthConfig(enabled=True, session_ttl_s=60), secrets_, path)
    auth.clock = clock
    auth.revoke(auth.issue())
    clock.now += 30
    auth.revoke(auth.issue())
    assert len(json.loads(path.read_text())["revoked"]) == 2
    clock.now += 45  # the first would have expired by now
    auth.revoke(auth.issue())
    assert len(json.loads(path.read_text())["revoked"]) == 2


def test_a_new_password_hash_ends_every_older_session() -> None:
    auth = make_auth()
    token = auth.issue()
    changed = OperatorAuth(AuthConfig(enabled=True), "ada", hash_password("a new one"), KEY)
    assert changed.operator_for(token) is None
    assert changed.operator_for(changed.issue()) == "ada"
    assert make_auth().operator_for(token) == "ada"  # same hash: still valid


def test_throttle_forgets_failures_after_a_success() -> None:
    throttle = LoginThrottle(2, 60, Clock())
    throttle.failed("a")
    throttle.succeeded("a")
    throttle.failed("a")
    assert throttle.retry_after("a") == 0


@pytest.mark.parametrize("host", ["127.0.0.1", "127.0.1.1", "::1", "[::1]", "localhost"])
def test_loopback_bind_is_allowed_without_auth(host: str) -> None:
    ensure_bind_allowed(host, auth_enabled=False)


@pytest.mark.parametrize("host", ["0.0.0.0", "::", "192.168.1.20", "robot.local"])
def test_public_bind_without_auth_is_refused_with_a_clear_message(host: str) -> None:
    with pytest.raises(PublicBindRefusedError, match=f"refusing to listen on {host}"):
        ensure_bind_allowed(host, auth_enabled=False)
    ensure_bind_allowed(host, auth_enabled=True)


def test_main_exits_2_before_binding_a_public_address_without_auth(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # keep the global structlog set-up untouched (it would hold capsys's stream)
    monkeypatch.setattr("robot_voice_chat.main.configure_logging", lambda *a: None)
    assert main(["--host", "0.0.0.0", "--port", "1"]) == 2
    captured = capsys.readouterr()
    assert "refusing to listen on 0.0.0.0" in captured.out + captured.err


@pytest.mark.parametrize(
    ("path", "protected"),
    [
        ("/api/livez", False),
        ("/api/readyz", False),
        ("/api/agent/events", False),
        ("/api/auth/login", False),
        ("/api/agent/missions", True),
        ("/api/agent/teaching", True),
        ("//api//agent/teaching", True),
        ("/api/livez/../agent/missions", True),
        ("/api/camera/frame.jpg", True),
        ("/socket.io/", True),
        ("/openapi.json", True),
        ("/docs", True),
        ("/", False),
        ("/assets/index.js", False),
    ],
)
def test_which_paths_need_a_login(path: str, protected: bool) -> None:
    assert requires_login(path) is protected


def test_session_cookie_is_read_from_the_cookie_header() -> None:
    scope = {"headers": [(b"cookie", b"theme=dark; rvc_session=abc.def")]}
    assert session_cookie(scope, "rvc_session") == "abc.def"
    assert session_cookie({"headers": []}, "rvc_session") is None
    assert session_cookie({"headers": [(b"cookie", b'bad"cookie')]}, "rvc_session") is None


async def test_trace_records_name_the_acting_operator(tmp_path: object) -> None:
    from pathlib import Path

    trace = TraceRecorder(Path(str(tmp_path)))
    with acting_operator("ada"):
        trace.record("m1", "instruction", instruction="go")
    trace.record("m1", "task_event", type="progress")
    first, second = await trace.read("m1")
    assert first["operator"] == "ada"
    assert "operator" not in second


def test_hash_password_command_prints_a_verifiable_hash(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr("sys.stdin", io.StringIO("a long password\n"))
    assert main(["hash-password", "--stdin"]) == 0
    printed = capsys.readouterr().out.strip()
    auth = OperatorAuth(AuthConfig(enabled=True), "operator", printed, KEY)
    assert auth.check_password("operator", "a long password")


def test_hash_password_command_refuses_a_short_password(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr("sys.stdin", io.StringIO("short\n"))
    assert hash_password_command(["--stdin"]) == 2
    assert "at least 8" in capsys.readouterr().err


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_hash_password_command_asks_twice_on_a_terminal(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    answers = iter(["first password", "other password"])
    monkeypatch.setattr("sys.stdin", _Terminal())
    monkeypatch.setattr("getpass.getpass", lambda prompt="": next(answers))
    assert hash_password_command([]) == 2
    assert "differ" in capsys.readouterr().err
