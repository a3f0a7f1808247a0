"""Ways of asking for a drive that say the same as "go to X" (issue 32): an escort ("take me to
X", "walk me over to X" — the robot drives there, the person follows), "I need you in X",
"send the robot to X", "swing by X", the robot in the third person ("could the robot go to
X", "have the robot drive to X", "the robot should go to X", "time to go home robot"), and
"home" said as a place. Each is rewritten to the words the grammar reads; nothing else is."""

from __future__ import annotations

import re

_ROBOT = r"(?:the robot|robot|the bot|yourself)"
_REWRITES: list[tuple[re.Pattern[str], str]] = [
    # ("stop by X" is not here: a sentence that starts with "stop" stops the robot)
    # the robot as the one spoken about: "could the robot please go", "have the robot drive"
    (re.compile(rf"^(?:can|could|would|will) {_ROBOT} (?:please )?"), ""),
    (re.compile(rf"^(?:have|get|tell|ask|make|let) {_ROBOT} (?:to )?"), ""),
    (re.compile(rf"^(?:i(?:'d| would) like|i want|i need) {_ROBOT} to "), ""),
    (re.compile(rf"^{_ROBOT},? (?:should|must|needs to|has to|will|can|could|is to|shall) "), ""),
    (re.compile(r"^(?:it(?:'s| is) )?time (?:for you |for the robot )?to "), ""),
    # an escort: the robot goes there
    (
        re.compile(
            r"^(?:take|bring|walk|escort|lead|guide|show|accompany|follow) (?:me|us)"
            r" (?:over |back |the way |along )?(?:to|into|towards|toward) "
        ),
        "go to ",
    ),
    (re.compile(r"^(?:escort|accompany|lead|guide) (?:me|us) "), "go to "),
    (re.compile(r"^show (?:me|us) (?:the way|how to get) to "), "go to "),
    # "I need you in X", "I need the robot at X", "I want you over at X"
    (
        re.compile(
            rf"^(?:i|we) (?:need|want|would like|'d like) (?:you|{_ROBOT}) (?:over |back |down )?"
            r"(?:in|at|to|into|by) "
        ),
        "go to ",
    ),
    (
        re.compile(rf"^(?:send|get|move|bring|drive) {_ROBOT} (?:over |back )?(?:to|into) "),
        "go to ",
    ),
    (
        re.compile(
            r"^(?:swing|pop|drop|pass|come|head|nip|run|duck) "
            r"(?:by|over to|over by|in to|into|round to|around to|down to|up to|over) "
        ),
        "go to ",
    ),
    (re.compile(r"^come (?:over |back )?(?:here )?(?:to|into) "), "go to "),
    # home as a place: "head home", "go back home", "return home", "go back to base"
    (
        re.compile(
            r"^(?:go|head|drive|return|come|get|move|run) (?:back )?(?:on )?(?:home|to home)\b"
        ),
        "go to home",
    ),
    (re.compile(r"^(?:go|head|drive|return|come|get|move) back (?:to )?base\b"), "go to base"),
]
# the robot addressed at the end: "time to go home robot", "go to the kitchen, robot"
_VOCATIVE = re.compile(r"(?<!\bthe)(?<!\ba)(?:,\s*|\s+)(?:robot|bot|buddy|mate)$")


def canonical(text: str) -> str:
    """``text`` (normalised) in the grammar's words where it is a known way of asking."""
    text = _VOCATIVE.sub("", text).strip(" ,")
    for pattern, replacement in _REWRITES:
        text = pattern.sub(replacement, text, count=1)
    return text
