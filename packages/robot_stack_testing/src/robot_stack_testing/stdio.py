"""Drive an MCP server over stdio as a host would, and keep everything it wrote.

:func:`stdio_session` sends ``initialize``, ``notifications/initialized`` and ``tools/list``,
then closes stdin (the host hangs up) and waits for the process to exit, so the transcript covers
start-up, the session and shutdown. :func:`non_protocol_lines` names every stdout line that is
not a JSON-RPC 2.0 message — a stdio server must write nothing else there.
:func:`inspector_tools_list` runs the MCP Inspector CLI (a third-party client, installed from
``tools/mcp-inspector`` by ``make setup``) the same way.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

PROTOCOL_VERSION = "2025-06-18"
INSPECTOR_DIR = Path(__file__).resolve().parents[4] / "tools" / "mcp-inspector"
INSPECTOR_BIN = INSPECTOR_DIR / "node_modules" / ".bin" / "mcp-inspector"


@dataclass(frozen=True)
class StdioTranscript:
    stdout: str
    stderr: str
    returncode: int

    def lines(self) -> list[str]:
        return [line for line in self.stdout.splitlines() if line.strip()]

    def messages(self) -> list[dict[str, Any]]:
        """The JSON-RPC messages on stdout (other lines skipped: see non_protocol_lines)."""
        messages = []
        for line in self.lines():
            try:
                message = json.loads(line)
            except ValueError:
                continue
            if isinstance(message, dict) and message.get("jsonrpc") == "2.0":
                messages.append(message)
        return messages


def _line(message: dict[str, Any]) -> bytes:
    return json.dumps(message).encode() + b"\n"


INITIALIZE = {
    "jsonrpc": "2.0",
    "id": 1,
    "method": "initialize",
    "params": {
        "protocolVersion": PROTOCOL_VERSION,
        "capabilities": {},
        "clientInfo": {"name": "stdio-check", "version": "0"},
    },
}
INITIALIZED = {"jsonrpc": "2.0", "method": "notifications/initialized"}
TOOLS_LIST = {"jsonrpc": "2.0", "id": 2, "method": "tools/list"}


def stdio_session(
    argv: Sequence[str], env: Mapping[str, str], cwd: Path, timeout_s: float = 60.0
) -> StdioTranscript:
    """Run ``argv`` as a stdio MCP server for one session: initialize, list tools, hang up.

    Each request is sent once the previous answer arrived (as a host does); then stdin closes
    and the process must exit on its own. Everything it wrote is kept; a missing answer or a
    process that outlives ``timeout_s`` fails with its stderr.
    """
    deadline = time.monotonic() + timeout_s
    proc = subprocess.Popen(  # noqa: S603 - argv list, no shell
        list(argv),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=cwd,
        env=dict(env),
    )
    assert proc.stdin is not None
    assert proc.stdout is not None
    assert proc.stderr is not None
    out: queue.Queue[bytes] = queue.Queue()
    err: list[bytes] = []
    readers = [
        threading.Thread(target=_pump, args=(proc.stdout, out.put), daemon=True),
        threading.Thread(target=_pump, args=(proc.stderr, err.append), daemon=True),
    ]
    for reader in readers:
        reader.start()
    lines: list[bytes] = []
    try:
        for request, answer_id in ((INITIALIZE, 1), (TOOLS_LIST, 2)):
            if request is TOOLS_LIST:
                proc.stdin.write(_line(INITIALIZED))
            proc.stdin.write(_line(request))
            proc.stdin.flush()
            _await_answer(out, lines, answer_id, deadline, err)
        proc.stdin.close()
        proc.wait(timeout=max(deadline - time.monotonic(), 0.1))
    except (subprocess.TimeoutExpired, TimeoutError) as error:
        proc.kill()
        proc.wait()
        for reader in readers:
            reader.join(timeout=5.0)
        raise AssertionError(
            f"{argv[0]}: {error}\n{b''.join(err).decode(errors='replace')[-3000:]}"
        ) from None
    finally:
        for reader in readers:
            reader.join(timeout=5.0)
        for stream in (proc.stdin, proc.stdout, proc.stderr):
            stream.close()
    while not out.empty():
        lines.append(out.get_nowait())
    return StdioTranscript(
        b"".join(lines).decode(errors="replace"),
        b"".join(err).decode(errors="replace"),
        proc.returncode,
    )


def _pump(stream: IO[bytes], sink: Callable[[bytes], None]) -> None:
    for line in iter(stream.readline, b""):
        sink(line)


def _await_answer(
    out: queue.Queue[bytes], lines: list[bytes], answer_id: int, deadline: float, err: list[bytes]
) -> None:
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError(f"no answer to request {answer_id}")
        try:
            line = out.get(timeout=remaining)
        except queue.Empty:
            continue
        lines.append(line)
        try:
            message = json.loads(line)
        except ValueError:
            continue
        if isinstance(message, dict) and message.get("id") == answer_id:
            return


def non_protocol_lines(transcript: StdioTranscript) -> list[str]:
    """Every stdout line that is not a JSON-RPC 2.0 object."""
    protocol = {json.dumps(m, sort_keys=True) for m in transcript.messages()}
    return [line for line in transcript.lines() if not _is_one_of(line, protocol)]


def _is_one_of(line: str, protocol: set[str]) -> bool:
    try:
        return json.dumps(json.loads(line), sort_keys=True) in protocol
    except ValueError:
        return False


def run_inspector(
    argv: Sequence[str],
    env: Mapping[str, str],
    cwd: Path,
    method: str = "tools/list",
    headers: Mapping[str, str] | None = None,
    timeout_s: float = 90.0,
) -> subprocess.CompletedProcess[str]:
    """``mcp-inspector --cli <argv> [-e K=V ...] [--header "K: V" ...] --method <method>``.

    ``argv`` is a server command (stdio: the inspector starts it with only the ``-e``
    variables) or an ``http(s)://…/sse`` / ``…/mcp`` URL, reached with ``headers`` (e.g. the
    server's credential: ``{"Authorization": "Bearer <token>"}``)."""
    if not INSPECTOR_BIN.is_file():
        raise AssertionError(
            f"{INSPECTOR_BIN} is missing: run `make setup` (npm ci in tools/mcp-inspector)"
        )
    command = [str(INSPECTOR_BIN), "--cli", *argv]
    for key, value in env.items():
        command += ["-e", f"{key}={value}"]
    for name, value in (headers or {}).items():
        command += ["--header", f"{name}: {value}"]
    command += ["--method", method]
    return subprocess.run(  # noqa: S603 - argv list, no shell
        command,
        capture_output=True,
        text=True,
        cwd=cwd,
        env={**os.environ, "NO_COLOR": "1"},
        timeout=timeout_s,
        check=False,
    )


def inspector_tools_list(
    argv: Sequence[str],
    env: Mapping[str, str],
    cwd: Path,
    timeout_s: float = 90.0,
    headers: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """The decoded answer of :func:`run_inspector`'s ``tools/list`` (fails when it fails)."""
    done = run_inspector(argv, env, cwd, headers=headers, timeout_s=timeout_s)
    if done.returncode != 0:
        raise AssertionError(f"the inspector failed ({done.returncode}):\n{done.stderr[-3000:]}")
    answer: dict[str, Any] = json.loads(done.stdout)
    return answer
