"""Stack placeholders (ports, frames folder) are overridable per run; busy ports are named;
one service can be restarted by PID."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from robot_stack_testing import free_tcp_port
from robot_stack_testing.stack import (
    StackError,
    busy_ports,
    free_port_overrides,
    load_stack,
    local_stack,
    stack_defaults,
)

HTTP_SERVER = (
    "import http.server, sys\n"
    "class H(http.server.BaseHTTPRequestHandler):\n"
    "    def do_GET(self):\n"
    "        self.send_response(200); self.end_headers(); self.wfile.write(b'ok')\n"
    "http.server.HTTPServer(('127.0.0.1', int(sys.argv[1])), H).serve_forever()\n"
)

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
