"""deploy/install.sh in a throwaway root (DESTDIR): files, permissions, secrets made once,
consistent units that `systemd-analyze verify` passes cleanly, one user per service that gets
only its own secrets, and --uninstall/--purge.

Not run here: real useradd/chown/systemctl (recorded in install-actions.log instead) and the
venv/UI build (--skip-build; it is `make setup`'s uv sync + build-interfaces + npm build)."""

from __future__ import annotations

import configparser
import os
import re
import shutil
import stat
import subprocess
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
INSTALL = ROOT / "deploy/install.sh"
UNITS = [
    "robot-mcp-perception",
    "mcp-skill-control",
    "mcp-perception-buffer",
    "robot-mcp-memory",
    "robot-mcp-navigation",
    "robot-mcp-manipulation",
    "robot-mcp-episodic",
    "robot-voice-chat",
    "robot-audio-listener",
]
HARDENING = {
    "NoNewPrivileges": "yes",
    "ProtectSystem": "strict",
    "PrivateTmp": "yes",
    "ProtectHome": "yes",
}
# MCP servers: their env file and the NAME of the brain's <NAME>_MCP_TOKEN (issue 27).
MCP_SERVERS = {
    "mcp-skill-control": ("skill-control", "SKILL_CONTROL"),
    "mcp-perception-buffer": ("perception-buffer", "PERCEPTION"),
    "robot-mcp-memory": ("memory", "MEMORY"),
    "robot-mcp-episodic": ("episodic", "EPISODIC"),
    "robot-mcp-navigation": ("navigation", "NAVIGATION"),
    "robot-mcp-manipulation": ("manipulation", "MANIPULATION"),
}


# MCP servers that check operators' approvals with a secret shared with the brain (issue 35).
APPROVAL_SERVERS = ("robot-mcp-memory", "robot-mcp-episodic")


def credentials_of(unit: str) -> set[str]:
    """An MCP server's two credentials: the brain's and the operators' tools' (and the
    approval secret of a server that checks approvals)."""
    file, _ = MCP_SERVERS[unit]
    approval = {f"MCP_APPROVAL_SECRET@{file}"} if unit in APPROVAL_SERVERS else set()
    return {f"MCP_AUTH_TOKEN@{file}", f"MCP_OPERATOR_TOKEN@{file}", *approval}


# The secrets each service needs (keys of its env files); nobody else may read them.
SECRETS_OF = {
    "robot-voice-chat": {
        "NAV_EVENT_SECRET",
        "PERCEPTION_EVENT_SECRET",
        "MANIP_EVENT_SECRET",
        "ADMIN_SECRET_KEY",
        "VISION_ARTIFACTS_TOKEN",
        *(f"{name}_MCP_TOKEN" for _, name in MCP_SERVERS.values()),
        *(f"{MCP_SERVERS[unit][1]}_APPROVAL_SECRET" for unit in APPROVAL_SERVERS),
    },
    "robot-mcp-navigation": {
        "RVC_EVENT_SECRET@navigation",
        *credentials_of("robot-mcp-navigation"),
    },
    "robot-mcp-manipulation": {
        "RVC_EVENT_SECRET@manipulation",
        *credentials_of("robot-mcp-manipulation"),
    },
    "mcp-perception-buffer": {
        "RVC_EVENT_SECRET@perception-buffer",
        *credentials_of("mcp-perception-buffer"),
    },
    "robot-mcp-perception": {"VISION_ARTIFACTS_TOKEN"},  # its pictures' (ARTIFACTS_AUTH_TOKEN)
    "mcp-skill-control": credentials_of("mcp-skill-control"),
    "robot-mcp-memory": credentials_of("robot-mcp-memory"),
    "robot-mcp-episodic": credentials_of("robot-mcp-episodic"),
    "robot-audio-listener": set(),  # the operator's password, set by hand (empty at install)
}


def run_install(destdir: Path, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        ["bash", str(INSTALL), *args],
        env={**os.environ, "DESTDIR": str(destdir), **env},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return result


def env_file(path: Path) -> dict[str, str]:
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return dict(ln.split("=", 1) for ln in lines)


def unit(path: Path) -> configparser.ConfigParser:
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str  # type: ignore[assignment,method-assign]
    parser.read_string(path.read_text())
    return parser


def unit_values(path: Path, key: str) -> list[str]:
    return [
        line.split("=", 1)[1]
        for line in path.read_text().splitlines()
        if line.startswith(f"{key}=")
    ]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("root")
    run_install(root, "--skip-build")
    return root


def test_code_is_installed_under_opt_robot_stack(installed: Path) -> None:
    opt = installed / "opt/robot-stack"
    assert (opt / "pyproject.toml").is_file()
    assert (opt / "uv.lock").is_file()
    assert (opt / "deploy/smoke.sh").is_file()
    assert (opt / "packages/robot_voice_chat/src/robot_voice_chat/main.py").is_file()
    # the package-internal config links survive the copy
    assert (opt / "packages/robot_voice_chat/src/robot_voice_chat/config/config.yaml").is_file()
    assert not (opt / ".git").exists()
    assert not (opt / ".venv").exists()  # --skip-build


def test_env_files_are_readable_by_root_only(installed: Path) -> None:
    etc = installed / "etc/robot-stack"
    assert stat.S_IMODE(etc.stat().st_mode) == 0o700
    files = sorted(p.name for p in etc.glob("*.env"))
    assert files == [
        "audio-listener.env",
        "brain.env",
        "episodic.env",
        "manipulation.env",
        "memory.env",
        "navigation.env",
        "operator.env",
        "perception-buffer.env",
        "ros.env",
        "skill-control.env",
        "vision.env",
    ]
    actions = (installed / "install-actions.log").read_text().splitlines()
    for name in files:
        assert stat.S_IMODE((etc / name).stat().st_mode) == 0o600, name
        assert f"chown root:root /etc/robot-stack/{name}" in actions
    assert "chown root:root /etc/robot-stack" in actions
    assert not [a for a in actions if "robot:" in a or ":robot " in a]


def secrets_readable_by(installed: Path, name: str) -> set[str]:
    """The secret values unit ``name`` can get: the env files systemd hands it (as root) —
    its own user can open no file under /etc/robot-stack (0700 root, files 0600 root)."""
    path = installed / "etc/systemd/system" / f"{name}.service"
    values: set[str] = set()
    for env in unit_values(path, "EnvironmentFile"):
        for key, value in env_file(installed / env.lstrip("/")).items():
            if value and re.search(r"SECRET|KEY|HASH|TOKEN", key):
                values.add(value)
    return values


def test_each_unit_runs_as_its_own_user_and_gets_only_its_own_secrets(installed: Path) -> None:
    etc = installed / "etc/robot-stack"
    brain, nav = env_file(etc / "brain.env"), env_file(etc / "navigation.env")
    buffer = env_file(etc / "perception-buffer.env")
    value_of = {
        **{k: v for k, v in brain.items() if v},
        "RVC_EVENT_SECRET@navigation": nav["RVC_EVENT_SECRET"],
        "RVC_EVENT_SECRET@perception-buffer": buffer["RVC_EVENT_SECRET"],
        "RVC_EVENT_SECRET@manipulation": env_file(etc / "manipulation.env")["RVC_EVENT_SECRET"],
    }
    for file, _ in MCP_SERVERS.values():
        server = env_file(etc / f"{file}.env")
        value_of[f"MCP_AUTH_TOKEN@{file}"] = server["MCP_AUTH_TOKEN"]
        value_of[f"MCP_OPERATOR_TOKEN@{file}"] = server["MCP_OPERATOR_TOKEN"]
        if "MCP_APPROVAL_SECRET" in server:
            value_of[f"MCP_APPROVAL_SECRET@{file}"] = server["MCP_APPROVAL_SECRET"]
    users = {}
    for name in UNITS:
        service = unit(installed / "etc/systemd/system" / f"{name}.service")["Service"]
        users[name] = service["User"]
        assert service["User"] == service["Group"] == name
        assert secrets_readable_by(installed, name) == {value_of[k] for k in SECRETS_OF[name]}, name
    assert len(set(users.values())) == len(UNITS)  # nobody shares a user
    # the vision node cannot read the operator's session key, the event secrets or any MCP
    # credential: only its own pictures' credential, which the brain's camera proxy holds
    assert secrets_readable_by(installed, "robot-mcp-perception") == {
        value_of["VISION_ARTIFACTS_TOKEN"]
    }


def test_event_secrets_are_generated_and_shared_with_the_brain(installed: Path) -> None:
    etc = installed / "etc/robot-stack"
    brain = env_file(etc / "brain.env")
    assert brain["NAV_EVENT_SECRET"] == env_file(etc / "navigation.env")["RVC_EVENT_SECRET"]
    assert (
        brain["PERCEPTION_EVENT_SECRET"]
        == env_file(etc / "perception-buffer.env")["RVC_EVENT_SECRET"]
    )
    assert brain["MANIP_EVENT_SECRET"] == env_file(etc / "manipulation.env")["RVC_EVENT_SECRET"]
    secrets = [
        brain["NAV_EVENT_SECRET"],
        brain["PERCEPTION_EVENT_SECRET"],
        brain["MANIP_EVENT_SECRET"],
        brain["ADMIN_SECRET_KEY"],
    ]
    assert len(set(secrets)) == 4
    assert all(len(s) >= 32 for s in secrets)
    assert brain["ADMIN_PASSWORD_HASH"] == ""  # the operator sets it (RUNBOOK step 3)


def test_every_mcp_server_gets_its_own_credentials_shared_with_the_brain_and_the_operator(
    installed: Path,
) -> None:
    """No MCP server runs open (issue 27): the brain holds each server's MCP_AUTH_TOKEN, the
    operators' tools (operator.env, read by no unit) each server's MCP_OPERATOR_TOKEN."""
    etc = installed / "etc/robot-stack"
    brain, operator = env_file(etc / "brain.env"), env_file(etc / "operator.env")
    tokens = []
    for unit_name, (file, name) in MCP_SERVERS.items():
        server = env_file(etc / f"{file}.env")
        assert brain[f"{name}_MCP_TOKEN"] == server["MCP_AUTH_TOKEN"], unit_name
        assert operator[f"{name}_MCP_OPERATOR_TOKEN"] == server["MCP_OPERATOR_TOKEN"], unit_name
        service = installed / "etc/systemd/system" / f"{unit_name}.service"
        assert "MCP_TRANSPORT=sse" in unit_values(service, "Environment"), unit_name
        assert not [e for e in unit_values(service, "Environment") if e.startswith("MCP_AUTH=")]
        tokens += [server["MCP_AUTH_TOKEN"], server["MCP_OPERATOR_TOKEN"]]
    for unit_name in APPROVAL_SERVERS:  # the brain signs approvals with the server's secret
        file, name = MCP_SERVERS[unit_name]
        approval = env_file(etc / f"{file}.env")["MCP_APPROVAL_SECRET"]
        assert brain[f"{name}_APPROVAL_SECRET"] == approval, unit_name
        tokens.append(approval)
    assert len(set(tokens)) == len(tokens)  # each token opens one server, for one principal
    assert all(len(t) >= 32 for t in tokens)
    for unit_name in UNITS:  # operator.env is no unit's
        service = installed / "etc/systemd/system" / f"{unit_name}.service"
        assert "/etc/robot-stack/operator.env" not in unit_values(service, "EnvironmentFile")
    assert not set(operator.values()) & secrets_readable_by(installed, "robot-voice-chat")


def test_navigation_is_installed_to_drive_the_robots_nav2_over_ros(installed: Path) -> None:
    navigation = env_file(installed / "etc/robot-stack/navigation.env")
    assert navigation["NAV_MOTION"] == "nav2"
    assert navigation["NAV2_ACTION"] == "/navigate_to_pose"
    assert navigation["NAV_POSE_TOPIC"] == "/amcl_pose"
    service = installed / "etc/systemd/system/robot-mcp-navigation.service"
    # the ROS domain of the vision node and Nav2, then the unit's own settings (which win)
    assert unit_values(service, "EnvironmentFile") == [
        "/etc/robot-stack/ros.env",
        "/etc/robot-stack/navigation.env",
    ]
    assert "/dev/shm" in unit_values(service, "ReadWritePaths")  # Fast DDS shared memory


def test_the_motion_servers_run_with_a_100_ms_dds_writer_heartbeat(installed: Path) -> None:
    """The lock and the feedback repair a lost sample in ~0.1 s (RUNBOOK "Supervision"); a robot's
    own profile in ros.env overrides the unit's line (EnvironmentFile= wins over Environment=)."""
    for name in ("robot-mcp-navigation", "robot-mcp-manipulation"):
        service = installed / f"etc/systemd/system/{name}.service"
        (profile,) = [
            v.split("=", 1)[1]
            for v in unit_values(service, "Environment")
            if v.startswith("FASTDDS_DEFAULT_PROFILES_FILE=")
        ]
        assert profile == "/opt/robot-stack/deploy/fastdds-motion-servers.xml"
        assert (installed / profile.lstrip("/")).is_file()
        assert unit_values(service, "EnvironmentFile")[0] == "/etc/robot-stack/ros.env"


def test_users_and_units_are_created_and_enabled(installed: Path) -> None:
    actions = (installed / "install-actions.log").read_text().splitlines()
    useradds = [a for a in actions if a.startswith("useradd ")]
    assert [a.split()[-1] for a in useradds] == UNITS
    assert all(a.startswith("useradd --system --user-group") for a in useradds)
    assert not [a for a in actions if a.startswith("usermod")]  # groups: SupplementaryGroups=
    enable = next(a for a in actions if a.startswith("systemctl enable "))
    assert enable.split()[2:] == ["robot-stack.target", *[f"{u}.service" for u in UNITS]]


def test_adding_a_service_is_its_unit_file_and_one_line(tmp_path: Path) -> None:
    source = tmp_path / "source"
    shutil.copytree(ROOT / "deploy", source / "deploy")
    nav = (source / "deploy/robot-mcp-navigation.service").read_text()
    (source / "deploy/robot-sim.service").write_text(
        nav.replace("robot-mcp-navigation", "robot-sim").replace(
            "EnvironmentFile=/etc/robot-stack/navigation.env",  # ros.env it reads already
            "EnvironmentFile=/etc/robot-stack/sim.env",
        )
    )
    script = source / "deploy/install.sh"
    text = script.read_text()
    script.write_text(
        text.replace(
            '  "robot-voice-chat brain"\n', '  "robot-voice-chat brain"\n  "robot-sim ros sim"\n'
        )
    )
    root = tmp_path / "root"
    run_install_from(script, root)
    assert stat.S_IMODE((root / "etc/robot-stack/sim.env").stat().st_mode) == 0o600
    assert (root / "etc/systemd/system/robot-sim.service").is_file()
    actions = (root / "install-actions.log").read_text()
    assert "--shell /usr/sbin/nologin robot-sim" in actions
    assert "robot-sim.service" in next(a for a in actions.splitlines() if "enable" in a)


def run_install_from(script: Path, root: Path) -> None:
    result = subprocess.run(
        ["bash", str(script), "--skip-build"],
        env={**os.environ, "DESTDIR": str(root)},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_unit_that_does_not_match_its_service_entry_is_refused(tmp_path: Path) -> None:
    """install.sh's SERVICES list and the unit files agree (user, env files), or no install."""
    source = tmp_path / "source"
    shutil.copytree(ROOT / "deploy", source / "deploy")
    brain = source / "deploy/robot-voice-chat.service"
    brain.write_text(
        brain.read_text().replace(
            "EnvironmentFile=/etc/robot-stack/brain.env",
            "EnvironmentFile=/etc/robot-stack/brain.env\nEnvironmentFile=/etc/robot-stack/vision.env",
        )
    )
    result = subprocess.run(
        ["bash", str(source / "deploy/install.sh"), "--skip-build"],
        env={**os.environ, "DESTDIR": str(tmp_path / "root")},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 2
    assert "robot-voice-chat: its EnvironmentFile= lines" in result.stderr


def test_the_vision_nodes_picture_credential_is_generated_and_shared_with_the_brain(
    installed: Path,
) -> None:
    """Issue 35: the vision node's camera frame, masks and overlays need ARTIFACTS_AUTH_TOKEN;
    the brain's camera proxy sends its copy, VISION_ARTIFACTS_TOKEN."""
    etc = installed / "etc/robot-stack"
    token = env_file(etc / "vision.env")["ARTIFACTS_AUTH_TOKEN"]
    assert len(token) >= 32
    assert env_file(etc / "brain.env")["VISION_ARTIFACTS_TOKEN"] == token
    service = installed / "etc/systemd/system/robot-mcp-perception.service"
    assert not [e for e in unit_values(service, "Environment") if e.startswith("ARTIFACTS_AUTH=")]


def test_rerunning_keeps_secrets_and_operator_edits(tmp_path: Path) -> None:
    run_install(tmp_path, "--skip-build")
    brain = tmp_path / "etc/robot-stack/brain.env"
    before = env_file(brain)
    brain.write_text(brain.read_text().replace("GROQ_API_KEY=", "GROQ_API_KEY=gsk-set-by-hand"))
    run_install(tmp_path, "--skip-build")
    after = env_file(brain)
    assert after["GROQ_API_KEY"] == "gsk-set-by-hand"
    for key in (
        "NAV_EVENT_SECRET",
        "PERCEPTION_EVENT_SECRET",
        "MANIP_EVENT_SECRET",
        "ADMIN_SECRET_KEY",
        "NAVIGATION_MCP_TOKEN",
        "EPISODIC_MCP_TOKEN",
        "VISION_ARTIFACTS_TOKEN",
    ):
        assert after[key] == before[key]
    assert list(after) == list(before)  # nothing appended twice


def test_a_given_password_hash_is_written_quoted_for_systemd(tmp_path: Path) -> None:
    digest = "$argon2id$v=19$m=65536,t=3,p=4$c2FsdA$aGFzaA"
    run_install(tmp_path, "--skip-build", ADMIN_PASSWORD_HASH=digest)
    brain = env_file(tmp_path / "etc/robot-stack/brain.env")
    assert brain["ADMIN_PASSWORD_HASH"] == f"'{digest}'"


def test_units_agree_on_paths_user_and_hardening(installed: Path) -> None:
    scripts: dict[str, str] = {}
    for pyproject in ROOT.glob("packages/*/pyproject.toml"):
        scripts.update(tomllib.loads(pyproject.read_text())["project"].get("scripts", {}))
    for name in UNITS:
        path = installed / "etc/systemd/system" / f"{name}.service"
        service = unit(path)["Service"]
        for key, value in HARDENING.items():
            assert service[key] == value, f"{name}: {key}"
        assert service["WorkingDirectory"] == "/opt/robot-stack"
        executable = service["ExecStart"].split()[0]
        assert executable.startswith("/opt/robot-stack/.venv/bin/")
        assert Path(executable).name in scripts, f"{name}: no console script {executable}"
        assert service["StateDirectory"] == name
        assert f"/var/lib/{name}" in unit_values(path, "ReadWritePaths")
        assert "AF_INET" in service["RestrictAddressFamilies"]
        for env in unit_values(path, "EnvironmentFile"):
            assert (installed / env.lstrip("/")).is_file(), f"{name}: {env} not installed"
        assert unit(path)["Install"]["WantedBy"] == "robot-stack.target"


def verify_root(installed: Path, tmp_path: Path) -> Path:
    """A copy of the throwaway root with the host's targets and stand-in executables
    (verify checks that ExecStart exists; --skip-build made no venv)."""
    root = tmp_path / "verify-root"
    shutil.copytree(installed, root, symlinks=True)
    system = root / "usr/lib/systemd/system"
    system.mkdir(parents=True)
    for target in Path("/lib/systemd/system").glob("*.target"):
        shutil.copy(target, system / target.name, follow_symlinks=True)
    bin_dir = root / "opt/robot-stack/.venv/bin"
    bin_dir.mkdir(parents=True)
    for name in UNITS:
        executable = unit(root / f"etc/systemd/system/{name}.service")["Service"]["ExecStart"]
        shim = bin_dir / Path(executable.split()[0]).name
        shim.write_text("#!/bin/sh\n")
        shim.chmod(0o755)
    return root


def test_systemd_analyze_verify_is_clean_on_every_unit(installed: Path, tmp_path: Path) -> None:
    analyze = shutil.which("systemd-analyze")
    assert analyze, "systemd-analyze is missing: `make setup` installs the systemd package"
    root = verify_root(installed, tmp_path)
    units = [f"/etc/systemd/system/{u}.service" for u in UNITS]
    result = subprocess.run(
        [analyze, "verify", f"--root={root}", *units, "/etc/systemd/system/robot-stack.target"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    # clean = no error AND no warning (unknown keys only warn, with exit code 0)
    assert (result.returncode, result.stdout + result.stderr) == (0, "")


def verify(root: Path, *units: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["systemd-analyze", "verify", f"--root={root}", *units],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_the_units_with_the_sros2_drop_ins_still_verify_clean(
    installed: Path, tmp_path: Path
) -> None:
    """RUNBOOK 5b installs deploy/sros2/systemd/<unit>.service.d/sros2.conf (issue 35)."""
    root = verify_root(installed, tmp_path)
    drop_ins = sorted((ROOT / "deploy/sros2/systemd").iterdir())
    for folder in drop_ins:
        (root / "etc/systemd/system" / folder.name).mkdir()
        shutil.copy(folder / "sros2.conf", root / "etc/systemd/system" / folder.name)
    units = [f"/etc/systemd/system/{f.name.removesuffix('.d')}" for f in drop_ins]
    clean = verify(root, *units)
    assert (clean.returncode, clean.stdout + clean.stderr) == (0, "")
    # verify reads the drop-ins: a typo in one is reported
    first = root / "etc/systemd/system" / drop_ins[0].name / "sros2.conf"
    first.write_text("[Service]\nEnviroment=ROS_SECURITY_ENABLE=true\n")
    typo = verify(root, units[0])
    assert "Enviroment" in typo.stdout + typo.stderr


def test_verify_catches_a_broken_unit(installed: Path, tmp_path: Path) -> None:
    """The check above can fail: a typo in a key is reported."""
    root = verify_root(installed, tmp_path)
    path = root / "etc/systemd/system/robot-voice-chat.service"
    path.write_text(path.read_text().replace("ProtectClock=", "ProtectClok="))
    result = subprocess.run(
        [
            "systemd-analyze",
            "verify",
            f"--root={root}",
            "/etc/systemd/system/robot-voice-chat.service",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert "ProtectClok" in result.stderr


def test_uninstall_removes_units_and_code_and_purge_removes_the_rest(tmp_path: Path) -> None:
    run_install(tmp_path, "--skip-build")
    (tmp_path / "var/lib/robot-mcp-memory").mkdir(parents=True)
    run_install(tmp_path, "--uninstall")
    assert not (tmp_path / "opt/robot-stack").exists()
    assert not list((tmp_path / "etc/systemd/system").iterdir())
    assert (tmp_path / "etc/robot-stack/brain.env").is_file()  # kept without --purge
    actions = (tmp_path / "install-actions.log").read_text()
    assert "systemctl disable --now robot-stack.target" in actions
    run_install(tmp_path, "--uninstall", "--purge")
    assert not (tmp_path / "etc/robot-stack").exists()
    assert not (tmp_path / "var/lib/robot-mcp-memory").exists()
    userdels = [
        a for a in (tmp_path / "install-actions.log").read_text().splitlines() if "userdel" in a
    ]
    assert userdels == [f"userdel {u}" for u in [*UNITS, "robot"]]


def test_unknown_arguments_are_refused(tmp_path: Path) -> None:
    result = subprocess.run(
        ["bash", str(INSTALL), "--frobnicate"],
        env={**os.environ, "DESTDIR": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 2
    assert "unknown argument --frobnicate" in result.stderr


def test_only_the_tls_proxy_joins_the_brains_group_for_its_proxy_socket(installed: Path) -> None:
    """Issue 31: forwarded headers are believed from the proxy socket, not from loopback."""
    brain = installed / "etc/systemd/system/robot-voice-chat.service"
    start = " ".join(unit_values(brain, "ExecStart"))
    socket = re.search(r"--proxy-socket (\S+)", start)
    assert socket is not None, start
    assert socket[1].startswith("/run/robot-voice-chat/")
    assert unit_values(brain, "RuntimeDirectory") == ["robot-voice-chat"]
    assert unit_values(brain, "RuntimeDirectoryMode") == ["0750"]
    caddyfile = (ROOT / "deploy/Caddyfile").read_text(encoding="utf-8")
    assert f"reverse_proxy unix/{socket[1]}" in caddyfile
    assert "reverse_proxy 127.0.0.1" not in caddyfile
    drop_in = installed / "etc/systemd/system/caddy.service.d/robot-stack.conf"
    assert unit_values(drop_in, "SupplementaryGroups") == ["robot-voice-chat"]
