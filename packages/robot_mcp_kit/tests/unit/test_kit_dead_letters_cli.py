"""The operator's dead-letter listing refuses clearly what it cannot read."""

from pathlib import Path

import pytest

from robot_mcp_kit.dead_letters import main


def test_a_missing_outbox_is_exit_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([str(tmp_path / "nope.sqlite3")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "no outbox file" in err


def test_a_file_that_is_not_an_outbox_is_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "x.sqlite3"
    path.write_bytes(b"not a database at all" * 10)
    assert main([str(path)]) == 2
    assert "cannot read" in capsys.readouterr().err
