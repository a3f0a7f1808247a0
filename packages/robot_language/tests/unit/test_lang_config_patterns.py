"""The grammar as data (issue 38 item 2): a file of named regular expressions or word lists under
``config/`` is compiled on load, a pattern may be written as the list of its alternatives, and a
broken or short file is refused with its name (and line, where the YAML says one)."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_language import config_file
from robot_language.config_file import PhrasingsError, patterns, word_lists
from robot_language.normalise import normalise


@pytest.fixture
def config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setattr(config_file, "CONFIG", tmp_path)
    return tmp_path


def test_a_pattern_written_as_its_alternatives_is_one_pattern(config: Path) -> None:
    (config / "site.yaml").write_text("go:\n  - '^go (?P<place>.+)$'\n  - '^head home$'\n")
    found = patterns("site", "go")
    assert found["go"].match("go kitchen")["place"] == "kitchen"  # type: ignore[index]
    assert found["go"].match("head home") is not None
    assert found["go"].match("drive home") is None


def test_a_pattern_that_does_not_compile_names_its_file_and_line(config: Path) -> None:
    (config / "site.yaml").write_text("go: '^go$'\nbroken: '^(go'\n")
    with pytest.raises(PhrasingsError, match=r"site\.yaml:2: broken"):
        patterns("site", "go", "broken")


def test_a_file_without_a_pattern_its_reader_needs_is_refused(config: Path) -> None:
    (config / "site.yaml").write_text("go: '^go$'\n")
    with pytest.raises(PhrasingsError, match=r"site\.yaml: no stop"):
        patterns("site", "go", "stop")


def test_word_lists_are_sets_of_words_and_a_yes_no_word_must_be_quoted(config: Path) -> None:
    (config / "words.yaml").write_text('marks: [wait, "no"]\n')
    assert word_lists("words", "marks")["marks"] == {"wait", "no"}
    (config / "words.yaml").write_text("bad: [wait, no]\n")  # YAML reads a bare no as false
    with pytest.raises(PhrasingsError, match=r"words\.yaml:1: bad"):
        word_lists("words", "bad")


def test_the_plain_normalise_only_lowers_straightens_and_spaces() -> None:
    heard = "Uh  go 2 the KITCHEN’s  door"
    assert normalise(heard, spoken=False) == "uh go 2 the kitchen's door"
    assert normalise(heard) == "go to the kitchen's door"
