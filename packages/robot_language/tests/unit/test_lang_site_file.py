"""Phrasings are data (issue 38 item 2): a site file adds a verb and a word for a place without
code, and a broken file is refused with its file and line."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_language.config_file import PhrasingsError
from robot_language.intents import load_intents
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding

FERRY = """\
intents:
  fetch:
    kind: action
    examples:
      - ferry the package from the mailroom to reception
    verbs: [ferry]
place_words:
  canteen: [kitchen]
"""
SAID = "ferry the package from the mailroom to the canteen"


def _codes(understanding: Understanding, text: str) -> list[str]:
    return understanding.understand(text, understanding.places(OFFICE_LIST_LOCATIONS)).code()


def test_a_site_verb_and_place_word_are_understood_without_code(
    understanding: Understanding, tmp_path: Path
) -> None:
    assert not any(code.startswith("fetch") for code in _codes(understanding, SAID))
    site = tmp_path / "site.yaml"
    site.write_text(FERRY, encoding="utf-8")
    with_site = Understanding(intents_files=[site])
    assert _codes(with_site, SAID) == ["fetch:package@mailroom>kitchen"]
    assert _codes(with_site, "go to the canteen") == ["goto:kitchen"]


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("intents:\n  fetch:\n    kind: action\n    examples: [a]\n    verbs: [ferry\n", ":6"),
        ("intents:\n  fetch:\n    kind: action\n    examples: [a]\n    verbs: 5\n", ":5"),
        ("intents:\n  bring:\n    kind: carry\n    examples: [a]\n", ":3"),
        ("objects: [mug]\nplace_words:\n  canteen: kitchen\n", ":3"),
        ("intents:\n  fetch:\n    kind: action\n    examples: [a]\n    vrebs: [ferry]\n", ":5"),
    ],
)
def test_a_broken_site_file_names_its_file_and_line(tmp_path: Path, text: str, where: str) -> None:
    site = tmp_path / "site.yaml"
    site.write_text(text, encoding="utf-8")
    with pytest.raises(PhrasingsError) as caught:
        load_intents([site])
    assert f"{site}{where}:" in str(caught.value)


def test_a_missing_site_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(PhrasingsError, match=r"can't read intents file .*absent\.yaml"):
        load_intents([tmp_path / "absent.yaml"])
