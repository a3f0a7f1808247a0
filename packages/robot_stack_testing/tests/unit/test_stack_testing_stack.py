"""The local-stack runner starts services in order, waits for readiness, and stops them;
its placeholders (ports, frames) are overridable per run and one service can be restarted."""

from __future__ import annotations

import socket
import sys
from pathlib import Path

import pytest

from robot_stack_testing import free_tcp_port
from robot_stack_testing.stack import (
    PortsBusyError,
    StackError,
    busy_ports,
    credential_placeholders,
    free_port_overrides,
    load_stack,
    local_stack,
    secret_placeholders,
    stack_credentials,
    stack_defaults,
    stack_environment,
    stack_secrets,
)

HTTP_SERVER = (
    "import http.server, sys\n"
    "class H(http.server.BaseHTTPRequestHandler):\n"
    "    def do_GET(self):\n"
    "        self.send_response(200); self.end_headers(); self.wfile.write(b'ok')\n"
    "http.server.HTTPServer(('127.0.0.1', int(sys.argv[1])), H).serve_forever()\n"
)


def write_stack(path: Path, body: str) -> Path:
    path.write_text(body)
    return path


def test_placeholders_expand_in_argv_env_and_urls(tmp_path: Path) -> None:
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        "  - name: a\n"
        '    argv: ["{python}", "-m", "x", "{root}/data"]\n'
        '    env: {DB: "{var}/a.sqlite3"}\n'
        '    ready: {http: "http://127.0.0.1:1/{var}", timeout_s: 3}\n',
    )
    [service] = load_stack(stack, {"python": "/py", "root": "/r", "var": "/v"})
    assert service.argv == ["/py", "-m", "x", "/r/data"]
    assert service.env == {"DB": "/v/a.sqlite3"}
    assert service.ready.http == "http://127.0.0.1:1//v"
    assert service.ready.timeout_s == 3.0


def test_services_start_in_order_become_ready_and_stop_on_exit(tmp_path: Path) -> None:
    http_port, tcp_port = free_tcp_port(), free_tcp_port()
    tcp_server = (
        "import socket, sys\n"
        "s = socket.socket(); s.bind(('127.0.0.1', int(sys.argv[1]))); s.listen()\n"
        "while True: s.accept()[0].close()\n"
    )
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        f'  - name: web\n    argv: ["{{python}}", "-c", {HTTP_SERVER!r}, "{http_port}"]\n'
        f'    ready: {{http: "http://127.0.0.1:{http_port}/", timeout_s: 20}}\n'
        f'  - name: tcp\n    argv: ["{{python}}", "-c", {tcp_server!r}, "{tcp_port}"]\n'
        f"    ready: {{tcp: {tcp_port}, timeout_s: 20}}\n",
    )
    with local_stack(tmp_path, tmp_path / "var", {}, stack_file=stack) as running:
        assert list(running) == ["web", "tcp"]
        assert all(process.running() for process in running.values())
    assert not any(process.running() for process in running.values())


def test_a_deferred_service_starts_alongside_and_is_ready_before_the_stack_is(
    tmp_path: Path,
) -> None:
    http_port = free_tcp_port()
    slow = tmp_path / "slow.py"
    slow.write_text("import time\ntime.sleep(1.0)\n" + HTTP_SERVER)
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        f'  - name: slow\n    argv: ["{{python}}", "{slow}", "{http_port}"]\n'
        f'    ready: {{http: "http://127.0.0.1:{http_port}/", timeout_s: 20, defer: true}}\n'
        '  - name: quick\n    argv: ["{python}", "-c", "import time; time.sleep(60)"]\n'
        "    ready: {timeout_s: 20}\n",
    )
    with local_stack(tmp_path, tmp_path / "var", {}, stack_file=stack) as running:
        assert list(running) == ["slow", "quick"]  # started in file order, not waited in it
        socket.create_connection(("127.0.0.1", http_port), timeout=1).close()  # ready by now


def test_only_starts_the_named_services(tmp_path: Path) -> None:
    port = free_tcp_port()
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        '  - name: skipped\n    argv: ["{python}", "-c", "raise SystemExit(3)"]\n'
        f'  - name: web\n    argv: ["{{python}}", "-c", {HTTP_SERVER!r}, "{port}"]\n'
        f'    ready: {{http: "http://127.0.0.1:{port}/", timeout_s: 20}}\n',
    )
    with local_stack(tmp_path, tmp_path / "var", {}, stack_file=stack, only={"web"}) as running:
        assert list(running) == ["web"]


def test_a_service_that_dies_fails_fast_with_its_log(tmp_path: Path) -> None:
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        "  - name: broken\n"
        '    argv: ["{python}", "-c", "print(\'config missing\'); raise SystemExit(2)"]\n'
        f"    ready: {{tcp: {free_tcp_port()}, timeout_s: 30}}\n",
    )
    with (
        pytest.raises(StackError, match="config missing"),
        local_stack(tmp_path, tmp_path / "var", {}, stack_file=stack),
    ):
        pass


def test_a_service_that_never_gets_ready_times_out_with_its_log(tmp_path: Path) -> None:
    sleeper = "print('still booting', flush=True); import time; time.sleep(60)"
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        f'  - name: slow\n    argv: ["{{python}}", "-c", {sleeper!r}]\n'
        f'    ready: {{http: "http://127.0.0.1:{free_tcp_port()}/", timeout_s: 1}}\n',
    )
    with (
        pytest.raises(StackError, match="slow not ready"),
        local_stack(tmp_path, tmp_path / "var", {}, stack_file=stack),
    ):
        pass


def test_the_repository_stack_file_names_every_server() -> None:
    root = Path(__file__).resolve().parents[4]
    path = root / "deploy" / "local-stack.yaml"
    with pytest.raises(StackError, match="no value for the placeholder"):
        load_stack(path, {"python": sys.executable, "root": "/r", "var": "/v"})
    names = stack_credentials(path)
    tokens = credential_placeholders(dict.fromkeys(names, "t"), dict.fromkeys(names, "o"))
    tokens |= secret_placeholders(dict.fromkeys(stack_secrets(path), "s"))
    services = load_stack(path, {"python": sys.executable, "root": "/r", "var": "/v", **tokens})
    assert [s.name for s in services] == [
        "robot_sim",
        "manipulation",
        "vision_node",
        "skill_control",
        "perception",
        "memory",
        "episodic",
        "navigation",
        "brain",
        "audio_listener",
    ]
    assert all(s.ready.tcp or s.ready.http or s.ready.pid_file for s in services)
    by_name = {s.name: s for s in services}
    assert by_name["navigation"].env["NAV_MOTION"] == "nav2"  # the real-robot data paths
    assert "frame_source=ros" in by_name["vision_node"].env["PERCEPTION_CONFIG_OVERRIDES"]
    assert by_name["robot_sim"].ready.pid_file == Path("/v/robot-sim.pid")
    # the microphone listener posts to this stack's brain (issue 36)
    assert by_name["audio_listener"].env["BRAIN_URL"] == "http://127.0.0.1:8000"


STACK = (
    "defaults:\n"
    '  web_port: "1"\n'
    '  data_dir: "{root}/data"\n'
    "services:\n"
    f'  - name: web\n    argv: ["{{python}}", "-c", {HTTP_SERVER!r}, "{{web_port}}"]\n'
    '    env: {DATA: "{data_dir}"}\n'
    '    ready: {http: "http://127.0.0.1:{web_port}/", timeout_s: 20}\n'
)
SUBSTITUTIONS = {"python": "/py", "root": "/r", "var": "/v"}


@pytest.fixture
def stack_file(tmp_path: Path) -> Path:
    path = tmp_path / "stack.yaml"
    path.write_text(STACK)
    return path


def test_defaults_expand_and_can_be_overridden_per_run(stack_file: Path) -> None:
    [default] = load_stack(stack_file, SUBSTITUTIONS)
    [override] = load_stack(stack_file, SUBSTITUTIONS, {"web_port": "4321", "data_dir": "/d"})

    assert default.env == {"DATA": "/r/data"}
    assert default.ready.http == "http://127.0.0.1:1/"
    assert override.argv[-1] == "4321"
    assert override.env == {"DATA": "/d"}
    assert stack_defaults(stack_file) == {"web_port": "1", "data_dir": "{root}/data"}


def test_an_unknown_override_is_refused_by_name(stack_file: Path) -> None:
    with pytest.raises(StackError, match="unknown stack placeholders: \\['wbe_port'\\]"):
        load_stack(stack_file, SUBSTITUTIONS, {"wbe_port": "1"})


def test_the_runners_own_substitutions_cannot_be_overridden(stack_file: Path) -> None:
    with pytest.raises(StackError, match="unknown stack placeholders: \\['python'\\]"):
        load_stack(stack_file, SUBSTITUTIONS, {"python": "/other/python"})


def test_a_stack_whose_port_is_held_refuses_to_start_and_starts_nothing(
    stack_file: Path, tmp_path: Path
) -> None:
    port = free_tcp_port()
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", port))
        holder.listen()
        with (
            pytest.raises(
                PortsBusyError, match=f"ports already in use on 127.0.0.1: {port} \\(web\\)"
            ),
            local_stack(
                tmp_path, tmp_path / "var", {}, stack_file, overrides={"web_port": str(port)}
            ),
        ):
            pass
    assert not (tmp_path / "var" / "web-0.log").exists()


def test_free_port_overrides_cover_every_port_placeholder(stack_file: Path) -> None:
    overrides = free_port_overrides(stack_file)

    assert list(overrides) == ["web_port"]
    assert int(overrides["web_port"]) > 1024


def test_busy_ports_names_the_service_whose_port_is_held(stack_file: Path) -> None:
    port = free_tcp_port()
    services = load_stack(stack_file, SUBSTITUTIONS, {"web_port": str(port)})
    assert busy_ports(services) == []

    with socket.socket() as holder:
        holder.bind(("127.0.0.1", port))
        holder.listen()
        assert busy_ports(services) == [("web", port)]


def test_restart_replaces_one_service_with_a_new_process(stack_file: Path, tmp_path: Path) -> None:
    overrides = free_port_overrides(stack_file)
    with local_stack(tmp_path, tmp_path / "var", {}, stack_file, overrides=overrides) as stack:
        first = stack["web"]
        second = stack.restart("web")

        assert not first.running()
        assert second.running()
        assert second.pid != first.pid
        assert stack["web"] is second
    assert not second.running()


def test_a_pid_file_service_is_ready_when_the_file_names_its_own_pid(tmp_path: Path) -> None:
    """A ROS node has no port: it writes its PID once ready. A stale file (another PID, from
    an earlier run) does not count."""
    pid_file = tmp_path / "var" / "node.ready"
    pid_file.parent.mkdir(parents=True)
    pid_file.write_text("1")
    writer = (
        "import os, sys, time, pathlib; time.sleep(0.3); "
        "pathlib.Path(sys.argv[1]).write_text(str(os.getpid())); time.sleep(60)"
    )
    stack = write_stack(
        tmp_path / "stack.yaml",
        "services:\n"
        f'  - name: node\n    argv: ["{{python}}", "-c", {writer!r}, "{{var}}/node.ready"]\n'
        '    ready: {pid_file: "{var}/node.ready", timeout_s: 20}\n',
    )
    with local_stack(tmp_path, tmp_path / "var", {}, stack_file=stack) as running:
        assert pid_file.read_text() == str(running["node"].pid)


def test_each_listed_server_gets_a_fresh_credential_per_run_on_both_sides(tmp_path: Path) -> None:
    echo_env = (
        "import os, sys, time; print(os.environ['MCP_AUTH_TOKEN'], flush=True); time.sleep(60)"
    )
    stack = write_stack(
        tmp_path / "stack.yaml",
        "credentials: [web]\n"
        "services:\n"
        f'  - name: web\n    argv: ["{{python}}", "-c", {echo_env!r}]\n'
        '    env: {MCP_AUTH_TOKEN: "{mcp_token_web}", BRAIN_SIDE: "{mcp_token_web}"}\n',
    )
    with local_stack(tmp_path, tmp_path / "a", {}, stack_file=stack) as first:
        token = first.credentials["web"]
        assert first.specs["web"].env == {"MCP_AUTH_TOKEN": token, "BRAIN_SIDE": token}
        assert first.operator_credentials["web"] not in (token, "")
    with local_stack(tmp_path, tmp_path / "b", {}, stack_file=stack) as second:
        assert second.credentials["web"] != token
    assert len(token) >= 32


def test_the_shipped_stack_gives_every_mcp_server_and_the_brain_the_same_credential() -> None:
    root = Path(__file__).resolve().parents[4]
    path = root / "deploy" / "local-stack.yaml"
    names = stack_credentials(path)
    tokens = {name: f"token-of-{name}" for name in names}
    operators = {name: f"operator-token-of-{name}" for name in names}
    placeholders = credential_placeholders(tokens, operators)
    placeholders |= secret_placeholders(dict.fromkeys(stack_secrets(path), "s"))
    substitutions = {"python": "py", "root": "r", "var": "v", **placeholders}
    services = {s.name: s for s in load_stack(path, substitutions)}
    for name in names:
        assert services[name].env["MCP_AUTH_TOKEN"] == tokens[name], name
        assert services[name].env["MCP_OPERATOR_TOKEN"] == operators[name], name
        assert services["brain"].env[f"{name.upper()}_MCP_TOKEN"] == tokens[name], name
    assert not set(operators.values()) & set(services["brain"].env.values())
    http_servers = {s for s, spec in services.items() if spec.env.get("MCP_TRANSPORT") == "sse"}
    assert http_servers == set(names)  # no MCP server of the stack runs open


def test_the_files_common_env_reaches_every_service_and_a_services_own_wins(
    tmp_path: Path,
) -> None:
    path = write_stack(
        tmp_path / "stack.yaml",
        "defaults:\n"
        '  profile: "{root}/p.xml"\n'
        "env:\n"
        '  PROFILE: "{profile}"\n'
        '  SHARED: "common"\n'
        "services:\n"
        '  - name: a\n    argv: ["{python}"]\n'
        '  - name: b\n    argv: ["{python}"]\n    env: {SHARED: "own", B: "{var}/b"}\n',
    )
    a, b = load_stack(path, SUBSTITUTIONS)
    assert a.env == {"PROFILE": "/r/p.xml", "SHARED": "common"}
    assert b.env == {"PROFILE": "/r/p.xml", "SHARED": "own", "B": "/v/b"}
    assert stack_environment(path, SUBSTITUTIONS, {"profile": "/o.xml"}) == {
        "PROFILE": "/o.xml",
        "SHARED": "common",
    }


def test_the_shipped_stack_hands_every_service_the_fast_dds_profile() -> None:
    root = Path(__file__).resolve().parents[4]
    path = root / "deploy" / "local-stack.yaml"
    names = stack_credentials(path)
    tokens = credential_placeholders(dict.fromkeys(names, "t"), dict.fromkeys(names, "o"))
    tokens |= secret_placeholders(dict.fromkeys(stack_secrets(path), "s"))
    substitutions = {"python": "py", "root": str(root), "var": "v", **tokens}
    profile = str(root / "deploy" / "fastdds-local.xml")
    for service in load_stack(path, substitutions):
        # Fast DDS 3 (the Kilted wheels) reads the first, Fast DDS 2 (Humble, Jazzy) the second
        assert service.env["FASTDDS_DEFAULT_PROFILES_FILE"] == profile, service.name
        assert service.env["FASTRTPS_DEFAULT_PROFILES_FILE"] == profile, service.name
    assert Path(profile).is_file()
    assert stack_environment(path, substitutions)["FASTDDS_DEFAULT_PROFILES_FILE"] == profile
