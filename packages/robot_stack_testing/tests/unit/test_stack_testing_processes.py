"""start_refusal: a module that refuses to start must do it the way the servers' rules say."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_stack_testing import start_refusal


def _module(tmp_path: Path, name: str, body: str) -> str:
    (tmp_path / f"{name}.py").write_text(body, encoding="utf-8")
    return name


def test_one_line_on_stderr_and_exit_2_is_a_refusal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # python -m finds modules in the working directory
    name = _module(
        tmp_path,
        "refuses",
        "import sys\nprint('x: cannot start: bad', file=sys.stderr)\nsys.exit(2)\n",
    )
    assert start_refusal(name, tmp_path, {}) == "x: cannot start: bad"


@pytest.mark.parametrize(
    "body",
    [
        "raise RuntimeError('boom')\n",  # a traceback, exit 1
        "import sys\nprint('noise')\nprint('x: bad', file=sys.stderr)\nsys.exit(2)\n",
        "import sys\nprint('a\\nb', file=sys.stderr)\nsys.exit(2)\n",
    ],
)
def test_a_traceback_stdout_noise_or_several_lines_is_not(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, body: str
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(AssertionError):
        start_refusal(_module(tmp_path, "misbehaves", body), tmp_path, {})
