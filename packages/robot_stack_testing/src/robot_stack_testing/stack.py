"""Start the local robot stack from ``deploy/local-stack.yaml`` and stop it again, by PID.

Used by ``make demo`` and the cross-package end-to-end tests. Services start in file order;
each one's readiness check (a TCP port, an HTTP 200, or a PID file naming the process — for
a ROS node with no port) must pass before the next starts, so
a broken service fails fast with its log tail instead of a hang further down.

MCP credentials: for every name under the file's ``credentials:`` the runner draws two fresh
tokens per run and expands ``{mcp_token_<name>}`` (the brain's: the server's
``MCP_AUTH_TOKEN`` and the brain's ``<NAME>_MCP_TOKEN``) and ``{mcp_operator_token_<name>}``
(an operator's tool's: the server's ``MCP_OPERATOR_TOKEN``); :attr:`LocalStack.credentials`
and :attr:`LocalStack.operator_credentials` hand them to the test.

Other per-run secrets: for every name under ``secrets:`` the runner draws one fresh token and
expands ``{secret_<name>}`` (e.g. the vision node's ``ARTIFACTS_AUTH_TOKEN`` and the brain's
``VISION_ARTIFACTS_TOKEN``); :attr:`LocalStack.secrets` hands them to the test.

State is private to this user (issue 35): the run's directory is 0700 (tightened when an
earlier run left it, or anything in it, readable to others), every service starts with umask
077 (its outboxes, ``memory.sqlite3``, episodic store and pose files are created 0600, its
directories 0700) and the runner's logs are 0600.

The file's top-level ``env:`` goes to every service (a service's own ``env:`` wins): the local
stack's Fast DDS profile (``deploy/fastdds-local.xml``: camera frames over shared memory).
:func:`stack_environment` gives it to processes a test or benchmark starts beside the stack.
"""

from __future__ import annotations

import sys
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from robot_stack_testing.mcp_auth import fresh_token
from robot_stack_testing.ports import free_tcp_port, tcp_port_free, wait_for_tcp_port
from robot_stack_testing.processes import LaunchedProcess, ProcessLauncher
from robot_stack_testing.waiting import wait_until


class StackError(RuntimeError):
    """A service did not become ready; the message carries the tail of its log."""


class PortsBusyError(StackError):
    """Something on 127.0.0.1 already holds ports the stack would listen on (another stack?);
    starting anyway would make the readiness checks answer for the wrong processes."""

    def __init__(self, busy: list[tuple[str, int]]) -> None:
        self.busy = busy
        held = ", ".join(f"{port} ({name})" for name, port in busy)
        super().__init__(f"ports already in use on 127.0.0.1: {held}")


@dataclass(frozen=True)
class Readiness:
    tcp: int | None = None
    http: str | None = None
    pid_file: Path | None = None
    """Ready once this file holds the process's own PID (a stale file from an earlier run
    names another PID and does not count)."""
    timeout_s: float = 30.0
    defer: bool = False
    """Start it, go on with the next services at once, and wait for it once all are started:
    a service nothing later needs at its own start-up (the brain reconnects) starts alongside
    the others instead of after them."""


@dataclass(frozen=True)
class ServiceSpec:
    name: str
    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)
    ready: Readiness = field(default_factory=Readiness)


def stack_defaults(path: Path) -> dict[str, str]:
    """The file's ``defaults:`` placeholders (ports, frame folder, …), unexpanded."""
    return _defaults(yaml.safe_load(path.read_text()))


def _defaults(document: dict[str, Any]) -> dict[str, str]:
    return {str(k): str(v) for k, v in (document.get("defaults") or {}).items()}


def stack_credentials(path: Path) -> list[str]:
    """The servers the file wants a per-run MCP credential for (its ``credentials:`` list)."""
    document: dict[str, Any] = yaml.safe_load(path.read_text())
    return [str(name) for name in document.get("credentials") or []]


def stack_secrets(path: Path) -> list[str]:
    """The names of the file's other per-run secrets (its ``secrets:`` list)."""
    document: dict[str, Any] = yaml.safe_load(path.read_text())
    return [str(name) for name in document.get("secrets") or []]


def secret_placeholders(secrets: Mapping[str, str]) -> dict[str, str]:
    """``{secret_<name>}`` for each secret."""
    return {f"secret_{name}": value for name, value in secrets.items()}


STATE_UMASK = 0o077
"""The umask of every process the local stack starts: files 0600, directories 0700."""


def make_private(directory: Path) -> None:
    """``directory`` (created if missing) and everything under it readable by this user
    only: 0700 / owner bits only for what an earlier run (or a wider umask) left open."""
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    directory.chmod(0o700)
    for path in directory.rglob("*"):
        if path.is_symlink():
            continue
        mode = path.stat().st_mode & 0o7777
        if mode & 0o077:
            path.chmod(mode & 0o700)


def credential_placeholders(
    credentials: Mapping[str, str], operator_credentials: Mapping[str, str] | None = None
) -> dict[str, str]:
    """``{mcp_token_<name>}`` for each credential, ``{mcp_operator_token_<name>}`` for each
    operator's one."""
    return {
        **{f"mcp_token_{name}": token for name, token in credentials.items()},
        **{f"mcp_operator_token_{n}": t for n, t in (operator_credentials or {}).items()},
    }


def port_placeholders(path: Path) -> list[str]:
    """The names of the ``*_port`` placeholders under ``defaults:``."""
    return [name for name in stack_defaults(path) if name.endswith("_port")]


def free_port_overrides(path: Path) -> dict[str, str]:
    """A free loopback port for every ``*_port`` placeholder (tests run beside a live stack)."""
    return {name: str(free_tcp_port()) for name in port_placeholders(path)}


def _expander(
    path: Path,
    document: dict[str, Any],
    substitutions: Mapping[str, str],
    overrides: Mapping[str, str] | None,
) -> Callable[[object], str]:
    defaults = _defaults(document)
    unknown = set(overrides or {}) - set(defaults)
    if unknown:
        raise StackError(f"unknown stack placeholders: {sorted(unknown)}")
    placeholders = dict(substitutions)
    for name, value in defaults.items():
        placeholders[name] = (overrides or {}).get(name, value).format_map(substitutions)

    def expand(value: object) -> str:
        try:
            return str(value).format_map(placeholders)
        except KeyError as missing:
            raise StackError(
                f"{path}: no value for the placeholder {{{missing.args[0]}}}"
            ) from None

    return expand


def stack_environment(
    path: Path, substitutions: Mapping[str, str], overrides: Mapping[str, str] | None = None
) -> dict[str, str]:
    """The file's top-level ``env:`` (what every service gets), expanded: for a process that
    runs as the stack's would (a benchmark's robot-sim, a test's)."""
    document: dict[str, Any] = yaml.safe_load(path.read_text())
    expand = _expander(path, document, substitutions, overrides)
    return {key: expand(value) for key, value in (document.get("env") or {}).items()}


def load_stack(
    path: Path, substitutions: Mapping[str, str], overrides: Mapping[str, str] | None = None
) -> list[ServiceSpec]:
    """Parse the stack file, expanding ``{python}``, ``{root}``, ``{var}`` and the
    ``defaults:`` placeholders (each replaced by ``overrides`` when given there); each
    service's environment is the file's ``env:`` updated with its own."""
    document: dict[str, Any] = yaml.safe_load(path.read_text())
    expand = _expander(path, document, substitutions, overrides)
    common = {key: expand(value) for key, value in (document.get("env") or {}).items()}
    services = []
    for entry in document.get("services", []):
        ready = entry.get("ready", {})
        services.append(
            ServiceSpec(
                name=entry["name"],
                argv=[expand(arg) for arg in entry["argv"]],
                env={
                    **common,
                    **{key: expand(value) for key, value in entry.get("env", {}).items()},
                },
                ready=Readiness(
                    tcp=int(expand(ready["tcp"])) if "tcp" in ready else None,
                    http=expand(ready["http"]) if "http" in ready else None,
                    pid_file=Path(expand(ready["pid_file"])) if "pid_file" in ready else None,
                    timeout_s=float(ready.get("timeout_s", 30.0)),
                    defer=bool(ready.get("defer", False)),
                ),
            )
        )
    return services


def service_ports(services: list[ServiceSpec]) -> list[tuple[str, int]]:
    """(service, port) for every readiness port: the ports the stack will listen on."""
    ports = []
    for service in services:
        if service.ready.tcp is not None:
            ports.append((service.name, service.ready.tcp))
        if service.ready.http is not None:
            port = urllib.parse.urlsplit(service.ready.http).port
            if port is not None:
                ports.append((service.name, port))
    return ports


def busy_ports(services: list[ServiceSpec]) -> list[tuple[str, int]]:
    """The stack's ports that something on 127.0.0.1 already holds."""
    return [(name, port) for name, port in service_ports(services) if not tcp_port_free(port)]


def http_ok(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=1.0) as response:  # noqa: S310 - loopback URL from the stack file
            return bool(response.status == 200)
    except (urllib.error.URLError, OSError):
        return False


def wait_ready(process: LaunchedProcess, ready: Readiness) -> None:
    def alive_and(check: bool) -> bool:
        if not process.running():
            raise StackError(f"{process.name} exited early:\n{process.log()[-3000:]}")
        return check

    try:
        if ready.tcp is not None:
            wait_until(lambda: alive_and(_tcp_open(ready.tcp or 0)), ready.timeout_s, process.name)
        if ready.http is not None:
            url = ready.http
            wait_until(lambda: alive_and(http_ok(url)), ready.timeout_s, process.name)
        if ready.pid_file is not None:
            path = ready.pid_file
            wait_until(
                lambda: alive_and(_names_pid(path, process.pid)), ready.timeout_s, process.name
            )
    except TimeoutError as error:
        raise StackError(f"{process.name} not ready: {error}\n{process.log()[-3000:]}") from error


def _names_pid(path: Path, pid: int) -> bool:
    try:
        return path.read_text().strip() == str(pid)
    except OSError:
        return False


def _tcp_open(port: int) -> bool:
    try:
        wait_for_tcp_port(port, 0.0)
    except TimeoutError:
        return False
    return True


@contextmanager
def local_stack(
    root: Path,
    var_dir: Path,
    env: Mapping[str, str],
    stack_file: Path | None = None,
    only: set[str] | None = None,
    overrides: Mapping[str, str] | None = None,
    credentials: Mapping[str, str] | None = None,
) -> Iterator[LocalStack]:
    """Run the stack (or the services named in ``only``) until the block exits; refuses to
    start (:class:`PortsBusyError`) when any of their ports is already held. ``credentials``
    (server → token; default: a fresh one for each name the file lists) fill the
    ``{mcp_token_<name>}`` placeholders.

    The yielded :class:`LocalStack` maps service names to their processes and can stop and
    restart one of them (same argv and environment)."""
    make_private(var_dir)
    path = stack_file or root / "deploy" / "local-stack.yaml"
    names = stack_credentials(path)
    if credentials is None:
        credentials = {name: fresh_token() for name in names}
    operators = {name: fresh_token() for name in names}
    secrets = {name: fresh_token() for name in stack_secrets(path)}
    substitutions = {
        "python": sys.executable,
        "root": str(root),
        "var": str(var_dir),
        **credential_placeholders(credentials, operators),
        **secret_placeholders(secrets),
    }
    services = [
        service
        for service in load_stack(path, substitutions, overrides)
        if only is None or service.name in only
    ]
    busy = busy_ports(services)
    if busy:
        raise PortsBusyError(busy)
    stack = LocalStack(
        ProcessLauncher(var_dir, umask=STATE_UMASK),
        root,
        dict(env),
        dict(credentials),
        operators,
        secrets,
    )
    try:
        deferred = [service for service in services if service.ready.defer]
        for service in services:
            if service.ready.defer:
                stack.launch(service)
            else:
                stack.start(service)
        for service in deferred:
            wait_ready(stack[service.name], service.ready)
        yield stack
    finally:
        stack.launcher.stop_all()


class LocalStack(dict[str, LaunchedProcess]):
    """The running services by name (file order)."""

    def __init__(
        self,
        launcher: ProcessLauncher,
        root: Path,
        env: dict[str, str],
        credentials: dict[str, str] | None = None,
        operator_credentials: dict[str, str] | None = None,
        secrets: dict[str, str] | None = None,
    ) -> None:
        super().__init__()
        self.launcher = launcher
        self.root = root
        self.env = env
        self.credentials = credentials or {}
        """This run's MCP credential of each server for the brain."""
        self.operator_credentials = operator_credentials or {}
        """This run's MCP credential of each server for an operator's tool."""
        self.secrets = secrets or {}
        """This run's other secrets by name (the file's ``secrets:``)."""
        self.specs: dict[str, ServiceSpec] = {}

    def launch(self, service: ServiceSpec) -> LaunchedProcess:
        """Start ``service`` without waiting for it to be ready."""
        process = self.launcher.start(
            service.name, service.argv, env={**self.env, **service.env}, cwd=self.root
        )
        self[service.name] = process
        self.specs[service.name] = service
        return process

    def start(self, service: ServiceSpec) -> LaunchedProcess:
        process = self.launch(service)
        wait_ready(process, service.ready)
        return process

    def restart(self, name: str) -> LaunchedProcess:
        """Stop one service by PID and start it again; returns the new process."""
        self.launcher.stop(self[name])
        return self.start(self.specs[name])
