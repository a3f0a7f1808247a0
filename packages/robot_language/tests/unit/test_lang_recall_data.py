"""Issue 38 for the grammar of questions about the past: its word lists are data
(``config/recall.yaml``, refused with file and line when broken), numbers said as words are read
by text_to_num where it agrees with the old table, and typos are read past by rapidfuzz exactly
where difflib's cut-off read them."""

from __future__ import annotations

import string
from difflib import SequenceMatcher
from pathlib import Path

import pytest
from text_to_num import text2num  # type: ignore[import-untyped]

from robot_language.config_file import PhrasingsError, read_model
from robot_language.recall import WHAT_HAPPENED, read_recall
from robot_language.recall.cleaning import TYPO_CUTOFF, closest
from robot_language.recall.phrasings import PHRASINGS, RECALL_PHRASINGS, RecallPhrasings
from robot_language.recall.times import number

# the number words the grammar read before text_to_num did, and what it read them as
OLD_NUMBERS = {
    "a": 1, "an": 1, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6,
    "seven": 7, "eight": 8, "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "fifteen": 15,
    "twenty": 20, "thirty": 30, "forty": 40, "forty five": 45, "fifty": 50, "sixty": 60,
    "ninety": 90, "a couple of": 2, "a couple": 2, "couple of": 2, "a few": 3, "few": 3,
}  # fmt: skip


def _text_to_num(words: str) -> int | None:
    try:
        return int(text2num(words, "en"))
    except ValueError:
        return None


def test_text_to_num_reads_every_old_number_word_it_knows_as_the_old_table_did() -> None:
    assert {w: number(w) for w in OLD_NUMBERS} == OLD_NUMBERS
    known = {w: v for w, v in OLD_NUMBERS.items() if _text_to_num(w) is not None}
    assert {w: _text_to_num(w) for w in known} == known
    # the other way round: what text_to_num can't read is exactly what the data file keeps
    assert set(OLD_NUMBERS) - set(known) == set(PHRASINGS.amounts)
    assert all(_text_to_num(w) is None for w in PHRASINGS.amounts)


@pytest.mark.parametrize(
    ("text", "start", "end"),
    [
        # the old table knew neither: "twenty five" was read as "five"
        ("what did you see twenty five minutes ago", "-2250s", "-750s"),
        ("what did you see twenty-five minutes ago", "-2250s", "-750s"),
        ("what did you see seventy seconds ago", "-105s", "-35s"),
        ("what happened in the last thirteen minutes", "-780s", None),
        ("what happened in the last forty-five minutes", "-2700s", None),
    ],
)
def test_numbers_beyond_the_old_table_are_read(text: str, start: str, end: str | None) -> None:
    recall = read_recall(text)
    assert recall is not None
    assert recall.tool == WHAT_HAPPENED
    assert (recall.arguments["start"], recall.arguments.get("end")) == (start, end)


def test_a_minute_past_the_hour_that_is_no_minute_is_no_clock_time() -> None:
    recall = read_recall("where were you at 0 minutes past 3")  # raised KeyError before
    assert recall is None


def _difflib_closest(word: str, vocabulary: list[str]) -> str:
    """The reading before rapidfuzz, as it was."""
    if word in vocabulary or len(word) < 3 or not word.isalpha():
        return word
    scored = sorted(((SequenceMatcher(None, word, v).ratio(), v) for v in vocabulary), reverse=True)
    cutoff = TYPO_CUTOFF / 100
    best = [v for ratio, v in scored if ratio >= cutoff and ratio == scored[0][0]]
    return best[0] if len(best) == 1 else word


def _one_edit(word: str) -> set[str]:
    letters = string.ascii_lowercase
    cuts = [(word[:i], word[i:]) for i in range(len(word) + 1)]
    return (
        {a + b[1:] for a, b in cuts if b}
        | {a + c + b[1:] for a, b in cuts if b for c in letters}
        | {a + c + b for a, b in cuts for c in letters}
        | {a + b[1] + b[0] + b[2:] for a, b in cuts if len(b) > 1}
    )


@pytest.mark.parametrize(
    ("vocabulary", "typo", "meant"),
    [(PHRASINGS.opening_words, "wher", "where"), (PHRASINGS.verbs, "spoted", "spotted")],
)
def test_rapidfuzz_corrects_every_one_letter_typo_as_difflib_did(
    vocabulary: list[str], typo: str, meant: str
) -> None:
    typos = sorted(set().union(*(_one_edit(v) for v in vocabulary)))
    corrected = {t: closest(t, vocabulary) for t in typos}
    assert corrected == {t: _difflib_closest(t, vocabulary) for t in typos}
    assert corrected[typo] == meant
    assert sum(t != c for t, c in corrected.items()) > 100  # the comparison is not vacuous


def test_the_shipped_phrasings_are_what_the_grammar_reads() -> None:
    recall = read_recall("u seen my package?")  # shorthand and a detector's word, from the file
    assert recall is not None
    assert recall.arguments == {"query": "parcel"}
    assert read_model(RECALL_PHRASINGS, RecallPhrasings, "recall phrasings") == PHRASINGS


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (("hedges: [about,", "hedges: [About,"), ": hedges.0:"),  # never matched: refused
        (("nothing: [", "nothin: [x]\nnothing: ["), ": nothin:"),  # a key the grammar does not read
        (("amounts: {a: 1,", "amounts: {a: 0,"), ": amounts.a:"),
        (("shorthand: {u: you,", "shorthand: {u: [you],"), ": shorthand.u:"),
        (("verbs: [see,", "verbs: [see,,"), ": while parsing"),  # broken YAML
    ],
)
def test_a_broken_phrasings_file_names_its_file_and_line(
    tmp_path: Path, change: tuple[str, str], where: str
) -> None:
    shipped = RECALL_PHRASINGS.read_text(encoding="utf-8")
    assert change[0] in shipped
    broken = shipped.replace(change[0], change[1])
    line = next(
        n for n, text in enumerate(broken.splitlines(), 1) if change[1].split("\n")[0] in text
    )
    path = tmp_path / "recall.yaml"
    path.write_text(broken, encoding="utf-8")
    with pytest.raises(PhrasingsError) as caught:
        read_model(path, RecallPhrasings, "recall phrasings")
    assert f"{path}:{line}{where}" in str(caught.value)
