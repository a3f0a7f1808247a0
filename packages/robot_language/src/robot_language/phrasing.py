"""Ways of asking for a drive that say the same as "go to X" (issue 32): an escort ("take me to
X", "walk me over to X" — the robot drives there, the person follows), "I need you in X",
"send the robot to X", "swing by X", the robot in the third person ("could the robot go to
X", "have the robot drive to X", "the robot should go to X", "time to go home robot"), and
"home" said as a place. Each is rewritten to the words the grammar reads; nothing else is. The
ways of asking are data: ``config/phrasing.yaml``."""

from __future__ import annotations

from robot_language.config_file import CONFIG, Regex, Strict, read_model


class _Rewrite(Strict):
    pattern: Regex
    to: str


class Rewrites(Strict):
    """``config/phrasing.yaml``: the ways of asking, in order, and the words each becomes."""

    vocative: Regex
    rewrites: list[_Rewrite]
    frames: list[_Rewrite]


REWRITES = read_model(CONFIG / "phrasing.yaml", Rewrites, "phrasing")


def canonical(text: str) -> str:
    """``text`` (normalised) in the grammar's words where it is a known way of asking."""
    text = REWRITES.vocative.sub("", text).strip(" ,")
    for rewrite in REWRITES.rewrites:
        text = rewrite.pattern.sub(rewrite.to, text, count=1)
    return text


def unframed(text: str) -> str:
    """``text`` (normalised) without the frame a request is wrapped in ("would you mind ...")."""
    for frame in REWRITES.frames:
        text = frame.pattern.sub(frame.to, text, count=1)
    return text.strip(" ,")
