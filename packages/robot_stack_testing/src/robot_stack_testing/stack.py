"""Start the local robot stack from ``deploy/local-stack.yaml`` and stop it again, by PID.

Used by ``make demo`` and the cross-package end-to-end tests. Services start in file order;
each one's readiness check (a TCP port or an HTTP 200) must pass before the next starts, so
a broken service fails fast with its log tail instead of a hang further down.
"""

from __future__ import annotations

import sys
import urllib.error
import urllib.request
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from robot_stack_testing.ports import wait_for_tcp_port
from robot_stack_testing.processes import LaunchedProcess, ProcessLauncher
from robot_stack_testing.waiting import wait_until


class StackError(RuntimeError):
    """A service did not become ready; the message carries the tail of its log."""


@dataclass(frozen=True)
class Readiness:
    tcp: int | None = None
    http: str | None = None
    timeout_s: float = 30.0


@dataclass(frozen=True)
class ServiceSpec:
    name: str
    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)
    ready: Readiness = field(default_factory=Readiness)


def load_stack(path: Path, substitutions: Mapping[str, str]) -> list[ServiceSpec]:
    """Parse the stack file, expanding ``{python}``, ``{root}``, ``{var}`` placeholders."""
    document: dict[str, Any] = yaml.safe_load(path.read_text())

    def expand(value: object) -> str:
        return str(value).format_map(substitutions)

    services = []
    for entry in document.get("services", []):
        ready = entry.get("ready", {})
        services.append(
            ServiceSpec(
                name=entry["name"],
                argv=[expand(arg) for arg in entry["argv"]],
                env={key: expand(value) for key, value in entry.get("env", {}).items()},
                ready=Readiness(
                    tcp=ready.get("tcp"),
                    http=expand(ready["http"]) if "http" in ready else None,
                    timeout_s=float(ready.get("timeout_s", 30.0)),
                ),
            )
        )
    return services


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
    except TimeoutError as error:
        raise StackError(f"{process.name} not ready: {error}\n{process.log()[-3000:]}") from error


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
) -> Iterator[dict[str, LaunchedProcess]]:
    """Run the stack (or the services named in ``only``) until the block exits."""
    var_dir.mkdir(parents=True, exist_ok=True)
    substitutions = {"python": sys.executable, "root": str(root), "var": str(var_dir)}
    services = load_stack(stack_file or root / "deploy" / "local-stack.yaml", substitutions)
    launcher = ProcessLauncher(var_dir)
    running: dict[str, LaunchedProcess] = {}
    try:
        for service in services:
            if only is not None and service.name not in only:
                continue
            process = launcher.start(
                service.name, service.argv, env={**env, **service.env}, cwd=root
            )
            running[service.name] = process
            wait_ready(process, service.ready)
        yield running
    finally:
        launcher.stop_all()
