"""Start-up refusals read as one line naming the problem."""

import pytest
from pydantic import BaseModel, Field, ValidationError

from robot_mcp_kit.startup import EXIT_CONFIG, describe, refuse_to_start


class Settings(BaseModel):
    port: int = Field(gt=0)
    name: str


def test_a_validation_error_is_described_by_its_first_field_and_a_count() -> None:
    with pytest.raises(ValidationError) as caught:
        Settings.model_validate({"port": 0})
    assert describe(caught.value) == "port: Input should be greater than 0 (and 1 more)"


def test_other_errors_are_one_line() -> None:
    assert describe(ValueError("bad\n  thing")) == "bad thing"
    assert describe(RuntimeError()) == "RuntimeError"


def test_refusing_exits_2_with_the_line_on_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as caught:
        refuse_to_start("svc", ValueError("MCP_PORT must be an integer"))
    assert caught.value.code == EXIT_CONFIG
    assert capsys.readouterr().err == "svc: cannot start: MCP_PORT must be an integer\n"
