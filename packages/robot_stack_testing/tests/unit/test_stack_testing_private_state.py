"""The local stack's state is private to its user (issue 35: outboxes, memory.sqlite3 and logs
were 0644 and the episodic directory 0755), and its per-run secrets reach the services."""

from __future__ import annotations

import stat
from pathlib import Path

from robot_stack_testing.stack import (
    load_stack,
    local_stack,
    secret_placeholders,
    stack_credentials,
    stack_secrets,
)
from robot_stack_testing.waiting import wait_until

# A service that creates state the way the servers do (sqlite outbox, a store directory, a
# JSON file), then writes its PID file (the readiness check) and waits.
SERVICE = (
    "import os, sqlite3, sys, time\n"
    "var = sys.argv[1]\n"
    "db = sqlite3.connect(os.path.join(var, 'outbox.sqlite3'))\n"
    "db.execute('create table t (x)'); db.commit(); db.close()\n"
    "os.makedirs(os.path.join(var, 'episodic', 'chunks'))\n"
    "open(os.path.join(var, 'episodic', 'chunks', 'c.json'), 'w').write('[]')\n"
    "open(os.path.join(var, 'svc.pid'), 'w').write(str(os.getpid()))\n"
    "time.sleep(60)\n"
)


def _modes(root: Path) -> dict[str, int]:
    return {
        str(path.relative_to(root)): stat.S_IMODE(path.stat().st_mode)
        for path in [root, *root.rglob("*")]
    }


def test_every_file_the_stack_and_its_services_create_is_0600_and_every_directory_0700(
    tmp_path: Path,
) -> None:
    var = tmp_path / "var"
    var.mkdir(mode=0o755)
    var.chmod(0o755)
    (var / "old.log").write_text("an earlier run's log")
    (var / "old.log").chmod(0o644)
    stack = tmp_path / "stack.yaml"
    stack.write_text(
        "services:\n"
        f'  - name: svc\n    argv: ["{{python}}", "-c", {SERVICE!r}, "{{var}}"]\n'
        '    ready: {pid_file: "{var}/svc.pid", timeout_s: 30}\n'
    )
    with local_stack(tmp_path, var, {}, stack_file=stack) as running:
        wait_until(lambda: (var / "episodic" / "chunks" / "c.json").exists(), 30.0, "state")
        modes = _modes(var)
        assert running["svc"].log_path.parent == var

    directories = {name for name in modes if (var / name).is_dir()}
    assert {"outbox.sqlite3", "episodic/chunks/c.json", "svc.pid", "old.log"} <= set(modes)
    assert any(name.startswith("svc-") and name.endswith(".log") for name in modes)
    assert {name: mode for name, mode in modes.items() if name in directories} == dict.fromkeys(
        directories, 0o700
    )
    assert {n: m for n, m in modes.items() if n not in directories} == {
        n: 0o600 for n in modes if n not in directories
    }


def test_a_per_run_secret_reaches_both_sides_and_differs_per_run(tmp_path: Path) -> None:
    stack = tmp_path / "stack.yaml"
    stack.write_text(
        "secrets: [pictures]\n"
        "services:\n"
        '  - name: a\n    argv: ["{python}", "-c", "pass"]\n'
        '    env: {SERVER_SIDE: "{secret_pictures}", CLIENT_SIDE: "{secret_pictures}"}\n'
    )
    with local_stack(tmp_path, tmp_path / "a", {}, stack_file=stack) as first:
        secret = first.secrets["pictures"]
        assert first.specs["a"].env == {"SERVER_SIDE": secret, "CLIENT_SIDE": secret}
    with local_stack(tmp_path, tmp_path / "b", {}, stack_file=stack) as second:
        assert second.secrets["pictures"] != secret
    assert len(secret) >= 32


def test_the_shipped_stack_gives_the_vision_node_and_the_brain_one_picture_credential() -> None:
    path = Path(__file__).resolve().parents[4] / "deploy" / "local-stack.yaml"
    names = stack_credentials(path)
    placeholders = {
        **{f"mcp_token_{n}": "t" for n in names},
        **{f"mcp_operator_token_{n}": "o" for n in names},
        **secret_placeholders(dict.fromkeys(stack_secrets(path), "s")),
        **secret_placeholders({"vision_artifacts": "the-picture-credential"}),
    }
    assert "vision_artifacts" in stack_secrets(path)
    services = {
        s.name: s
        for s in load_stack(path, {"python": "py", "root": "r", "var": "v", **placeholders})
    }
    assert services["vision_node"].env["ARTIFACTS_AUTH_TOKEN"] == "the-picture-credential"
    assert services["brain"].env["VISION_ARTIFACTS_TOKEN"] == "the-picture-credential"
