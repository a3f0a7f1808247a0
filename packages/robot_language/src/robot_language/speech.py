"""Speech-style input written the way the grammar reads it (issue 32): what a speech-to-text
engine or a hurried thumb leaves in a request, taken out before anything else reads it.

- casing, curly apostrophes, and one word per sentence ("Go. To. The. Meeting. Room.");
- hesitations and fillers ("uh", "um", "like" as a filler), stutters ("go go to the the kitchen");
- texting spellings ("u", "2", "pls", "thx") and contractions typed without their apostrophe
  ("dont", "whats", "theres");
- possessives without their apostrophe, against the live places ("bobs desk" → "bob's desk"
  when a place is Bob's);
- spoken numbers as digits ("room twenty three" → "room 23"), by ``text2num`` (MIT); small isolated
  numbers and ordinals ("two", "first", "a second") are left as words.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from text_to_num import alpha2digit  # type: ignore[import-untyped]

_HESITATIONS = {
    "uh", "uhh", "uhm", "um", "umm", "uhhh", "ummm", "hmm", "hm", "hmmm", "er", "erm", "err",
    "ah", "ahh", "eh", "mm", "mmm", "mhm",
}  # fmt: skip
_TEXTING = {
    "u": "you", "ya": "you", "ur": "your", "yr": "your", "pls": "please", "plz": "please",
    "pleez": "please", "thx": "thanks", "thnx": "thanks", "thanx": "thanks", "tnx": "thanks",
    "ty": "thank you", "k": "ok", "kk": "ok", "okey": "okay", "n": "and", "wat": "what",
    "wut": "what", "wht": "what", "wer": "where", "whr": "where", "cud": "could", "wud": "would",
    "cn": "can", "b4": "before", "rn": "right now", "gonna": "going to", "wanna": "want to",
    "gotta": "got to", "lemme": "let me", "gimme": "give me", "im": "i'm", "abt": "about",
    "cuz": "because", "coz": "because", "bc": "because", "sry": "sorry", "srry": "sorry",
    "nvm": "never mind", "idk": "i don't know", "tmr": "tomorrow", "msg": "message",
}  # fmt: skip
# contractions typed without the apostrophe (words that are also words, "its", "were", "ill",
# "wont", are left alone)
_CONTRACTIONS = {
    "dont": "don't", "doesnt": "doesn't", "didnt": "didn't", "cant": "can't", "isnt": "isn't",
    "arent": "aren't", "wasnt": "wasn't", "werent": "weren't", "shouldnt": "shouldn't",
    "couldnt": "couldn't", "wouldnt": "wouldn't", "havent": "haven't", "hasnt": "hasn't",
    "whats": "what's", "wheres": "where's", "hows": "how's", "whos": "who's", "thats": "that's",
    "theres": "there's", "heres": "here's", "lets": "let's", "youre": "you're",
    "theyre": "they're", "ive": "i've", "youve": "you've", "youll": "you'll", "itll": "it'll",
    "shes": "she's", "hes": "he's", "whens": "when's",
}  # fmt: skip
_ID_BEFORE = {"like", "love", "rather", "prefer", "want"}  # "id like" → "i'd like"
# "2" / "4" are "to" / "for" next to these words ("go 2 the kitchen", "look 4 the mug")
_TO_AFTER = {
    "go", "come", "get", "drive", "head", "back", "way", "over", "it", "them", "me", "up",
    "going", "want", "need", "have", "got", "bring", "take", "move", "walk", "return", "this",
    "that", "trip", "visit", "down", "out", "next", "like", "proceed", "navigate",
}  # fmt: skip
_BEFORE_TO = {
    "the", "a", "an", "my", "your", "our", "his", "her", "their", "me", "you", "go", "get",
    "bring", "see", "find", "check", "look", "reception", "kitchen", "home", "base",
}  # fmt: skip
_FOR_AFTER = {"look", "looking", "search", "searching", "watch", "wait", "check", "out", "ask"}
# after these, "like" is a verb or a comparison, not a filler
_LIKE_KEEPS = {
    "i", "you", "we", "they", "he", "she", "it", "would", "i'd", "you'd", "we'd", "d", "looks",
    "look", "looked", "something", "anything", "nothing", "feel", "feels", "things", "don't",
    "do", "does", "didn't", "did",
}  # fmt: skip
_LEADING = re.compile(r"^(?:(?:so|well|alright|all right|oh|yo|okay so|ok so|right,)[\s,]+)+")
_YOU_KNOW = re.compile(r"(?:^|,)\s*you know\s*(?:,|$)")
_SENTENCES = re.compile(r"[.!?]+")
_WORD = re.compile(r"[\w']+")
_NUMBER_WORDS = re.compile(
    r"\b(?:one|two|three|four|five|six|seven|eight|nine|ten|eleven|twelve|thirteen|fourteen|"
    r"fifteen|sixteen|seventeen|eighteen|nineteen|twenty|thirty|forty|fifty|sixty|seventy|"
    r"eighty|ninety|hundred|thousand)\b"
)


def possessors(names: Iterable[str]) -> set[str]:
    """The people whose places the map has ("Alice's desk" → alice), from place texts."""
    return {m.lower() for text in names for m in re.findall(r"\b(\w+)['’]s\b", text)}


def normalise(text: str, owners: Iterable[str] = ()) -> str:
    """``text`` as the grammar reads it; ``owners``: names whose possessive a place uses
    ("bob" for "Bob's desk"), so "bobs desk" gets its apostrophe back."""
    text = " ".join(text.replace("’", "'").replace("‘", "'").lower().split())
    text = _one_word_sentences(text)
    text = _words(text, {f"{o}s": f"{o}'s" for o in owners})
    text = _drop_repeated_pairs(text)
    text = _YOU_KNOW.sub(",", text).strip(" ,")
    text = _LEADING.sub("", text)
    if _NUMBER_WORDS.search(text):
        text = alpha2digit(text, "en")
    return " ".join(text.split())


def _one_word_sentences(text: str) -> str:
    """ "go. to. the. meeting. room." → "go to the meeting room": three or more sentences of
    one or two words each are one sentence said slowly."""
    pieces = [p.strip() for p in _SENTENCES.split(text) if p.strip()]
    if len(pieces) >= 3 and all(len(p.split()) <= 2 for p in pieces):
        return " ".join(pieces)
    return text


def _word(heard: str, before: str, after: str, owned: dict[str, str]) -> str:
    if heard in _HESITATIONS:
        return ""
    if heard == "like" and before not in _LIKE_KEEPS:
        return ""
    if heard == "2" and (before in _TO_AFTER or after in _BEFORE_TO):
        return "to"
    if heard == "4" and (before in _FOR_AFTER or after in _BEFORE_TO):
        return "for"
    if heard == "r" and (before in {"where", "what", "how", "who", "why", "when", "you"}
                         or after in {"you", "u"}):  # fmt: skip
        return "are"
    if heard == "id" and after in _ID_BEFORE:
        return "i'd"
    if heard in owned:
        return owned[heard]
    return _TEXTING.get(heard) or _CONTRACTIONS.get(heard) or heard


def _words(text: str, owned: dict[str, str]) -> str:
    """Each word as the grammar reads it, looking at its neighbours; punctuation, clock times
    ("15:30") and everything between the words are kept as they were."""
    found = list(_WORD.finditer(text))
    out: list[str] = []
    kept = ""  # the last word written
    end = 0
    for i, match in enumerate(found):
        after = found[i + 1][0] if i + 1 < len(found) else ""
        word = _word(match[0], kept, after, owned)
        gap = text[end : match.start()]
        end = match.end()
        if not word or (word == kept and word.isalpha() and not gap.strip()):  # "the the"
            out.append(gap if gap.strip() else "")
            continue
        out += [gap, word]
        kept = word
    out.append(text[end:])
    joined = "".join(out)
    joined = re.sub(r"\s+([,.!?;:])(?!\d)", r"\1", joined)
    return re.sub(r"([,;])(?:\s*[,;])+", r"\1", " ".join(joined.split()))


def _drop_repeated_pairs(text: str) -> str:
    """ "go to go to the kitchen" → "go to the kitchen" (a restart of the same two words)."""
    return re.sub(r"\b(\w+ \w+) \1\b", r"\1", text)
