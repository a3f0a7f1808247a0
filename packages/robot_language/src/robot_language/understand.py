"""The embedded understanding layer: the exact grammar first, then semantic intent matching
over the examples of ``intents.yaml``; slots resolved against the live places; legs composed
in order. Whatever it is unsure of becomes one question, never an action."""

from __future__ import annotations

import re
import time
from collections.abc import Collection
from dataclasses import replace
from pathlib import Path
from typing import Literal

import structlog

from robot_language import clauses as cl
from robot_language import composites, fuzzy, guards, negation, phrasing, saying
from robot_language.check import check, check_answer
from robot_language.commands import parse
from robot_language.composing import (
    Leg,
    compose,
    share_place,
    spells_a_place,
    unclear,
    unknown_place,
)
from robot_language.config_file import word_lists
from robot_language.embedder import Embedder, default_embedder
from robot_language.followup import follow_up
from robot_language.intents import load_intents
from robot_language.normalise import normalise
from robot_language.places import PlaceIndex, PlaceMatch, could_name_a_place
from robot_language.questions import read_question
from robot_language.reading import Action, ActionKind, Question, Reading, _with
from robot_language.recall import default_recall, looks_like_recall, read_recall
from robot_language.roles import DEFAULT_ROLES, read_roles, role_words, said_plainly

logger = structlog.get_logger(__name__)
NOT_READ_RECALL = (
    "I did not understand that question about the past. You can ask, for example: 'when did "
    "you last see the mug?', 'what did you see 5 minutes ago?', 'what happened while I was "
    "away?' or 'where were you at 3 pm?'"
)
_THING = re.compile(r"^(?:the|a|an|my|your|our|his|her|their|this|that|some)\s")


class Understanding:
    """``understand(text, places)`` → :class:`Reading`; ``follow_up(question, answer, places)``
    reads the answer to a question it asked."""

    def __init__(
        self,
        embedder: Embedder | None = None,
        intents_files: list[Path] | None = None,
        roles_file: Path | None = None,
        act_threshold: float = 0.55,
        ask_threshold: float = 0.35,
        margin: float = 0.03,
    ) -> None:
        self.intents = load_intents(intents_files)
        words = role_words(roles_file or DEFAULT_ROLES)
        carrying = {"fetch", "deliver"}
        own = [v for n in carrying for v in self.intents.intents[n].verbs]
        other = [v for n, i in self.intents.intents.items() if n not in carrying for v in i.verbs]
        verbs = list(dict.fromkeys([*words.carry_verbs, *own]))
        self.roles = words.model_copy(update={"carry_verbs": verbs, "other_verbs": other})
        self.embedder = embedder or default_embedder()
        self.act_threshold, self.ask_threshold, self.margin = act_threshold, ask_threshold, margin
        self._labels = [n for n, i in self.intents.intents.items() for _ in i.examples]
        examples = [e for i in self.intents.intents.values() for e in i.examples]
        self._examples = self.embedder.embed([normalise(e, spoken=False) for e in examples])
        self._things = frozenset(
            word_lists("words", "things")["things"] | set(self.intents.objects)
        )

    @property
    def name(self) -> str:
        return f"embedded matcher ({self.embedder.name})"

    def places(self, list_locations_result: str) -> PlaceIndex:
        return PlaceIndex.from_result(list_locations_result, self.intents.place_words)

    # --- one request ------------------------------------------------------------------------
    def understand(
        self, text: str, places: PlaceIndex | None = None, seen: Collection[str] = ()
    ) -> Reading:
        """``seen``: the things the robot has seen (episodic memory's labels, as spoken): a
        misspelt thing is read as one of them when it clearly is. Not checked for as unused
        objects: a label such as "desk" or "door" is also a word of places and requests."""
        started = time.monotonic()
        heard = normalise(text, places.owners() if places is not None else ())
        reading, ruled_out = self._understand(heard, places)
        things = self._things.union(seen)
        spelt = [replace(a, obj=fuzzy.respelt(a.obj, things)) if a.obj else a
                 for a in reading.actions]  # fmt: skip
        # the CHECK stage: the one point every reading passes before anything acts on it
        reading = check(
            heard, replace(reading, actions=spelt), places, ruled_out, self.intents.objects
        )
        logger.debug("understanding_read", reading=reading.code(), intent=reading.intent,
                     stage=reading.stage, score=round(reading.score, 3),
                     duration_ms=round((time.monotonic() - started) * 1000, 2))  # fmt: skip
        return reading

    def _understand(self, text: str, places: PlaceIndex | None) -> tuple[Reading, set[str]]:
        """The reading of ``text`` (normalised) and the places the person ruled out."""
        recall = read_recall(text)  # a question about the past: answered, never acted on
        if recall and recall.offer and places and recall.obj and spells_a_place(places, recall.obj):
            recall = None  # "where is the kitchen": a place, not a thing last seen
        if recall is not None:
            return Reading("answer", topic="history", recall=recall, intent="history"), set()
        if looks_like_recall(text):  # about the past, but not read: never an action from it
            return Reading("refuse", text=NOT_READ_RECALL, intent="history"), set()
        unframed = phrasing.unframed(text)  # "would you mind nipping over to X"
        said = negation.read(unframed, lambda phrase: guards.names_a_place(places, phrase))
        negated = guards.negated_places(said.negated, places)
        if said.only_negative:
            return self._declined(said.refused, places), set()
        if negation.still_negated(said.text):
            return unclear(text), set()  # a "not" we could not place: nothing acted or proposed
        if places is not None and negated:
            places = places.excluding(negated)
        body, rounds = composites.rounds(said_plainly(said.text, self.roles))
        parts = [c for p in cl.clauses(composites.patrol(body)) if (c := phrasing.canonical(p))]
        if not parts:
            return unclear(text), set()
        wholes = [body, cl.tidy(body), *(parts[:1] if len(parts) == 1 else [])]
        for whole in dict.fromkeys(wholes):
            asked = self._question(whole, places)  # "thanks, that's all" is one sentence
            if asked is not None:
                return asked, set()
        if len(parts) == 1 and parse(parts[0]).kind == "unknown":
            single = self._non_action(parts[0])
            if single is not None:
                return single, set()
        legs: list[Leg] = []
        for part in parts:
            legs.append(
                self._delivery(part, legs, places)
                or self._more_objects(part, legs, places)
                or self._leg(part, places)
            )
        share_place(legs)
        reading = compose(text, legs, places)
        return guards.respect(guards.repeated(reading, rounds, places), negated, places), negated

    def _question(self, part: str, places: PlaceIndex | None) -> Reading | None:
        """How far / which way to a place, the time, what the robot is doing, small talk,
        thanks, continue: answered (never an offer to move)."""
        asked = read_question(part)
        if asked is None:
            return None
        reading = Reading("answer", topic=asked.topic, text=asked.reply, intent=asked.topic,
                          stage="answer")  # fmt: skip
        if asked.place is None:
            return reading
        match = places.resolve(asked.place) if places is not None else None
        if match is None or not match.names:
            if part.startswith("where"):  # "where is the mug": not a place, not this question
                return None
            return Reading("refuse", text=unknown_place(asked.place, places),
                           intent="distance")  # fmt: skip
        if not match.sure:
            labels = " or ".join(saying.place_of(n, places) for n in match.names)
            return replace(reading, text=f"Which place do you mean: {labels}?")
        return replace(reading, about=match.names[0])

    def _declined(self, refused: str, places: PlaceIndex | None) -> Reading:
        """Only what not to do was said ("don't go to the kitchen"): nothing is done."""
        leg = self._leg(phrasing.canonical(cl.tidy(refused)), places)
        what = saying.plan([leg.action], places) if leg.status == "ok" and leg.action else ""
        text = f"OK, I won't {what}." if what else "OK, I won't do that."
        return Reading("cancel", text=text, intent="negated", stage="grammar")

    def _more_objects(self, part: str, before: list[Leg], places: PlaceIndex | None) -> Leg | None:
        """ "look for the scissors and a yellow package", "bring the mug and the bottle": a part
        with no verb right after a search (a fetch) is another object of it, fetched in turn."""
        previous = before[-1].action if before else None
        kind = previous.kind if previous is not None and previous.to is None else None
        if kind == "fetch" and (
            before[-1].status not in ("ok", "missing") or not _THING.match(part)
        ):
            return None  # "forget reception, head straight to X": no second thing to carry
        if kind not in ("find", "fetch"):
            return None
        if (
            parse(part).kind != "unknown"
            or self._verb(part) is not None
            or cl.SEARCH_IN.match(part)
            or (places is not None and places.only_place(part))
            or read_question(part) is not None
        ):
            return None
        leg = self._leg(f"{kind} {part}", places)
        if leg.action is None or leg.action.kind != kind:
            return None
        leg.text, leg.more = part, True
        leg.sure = leg.sure and kind == "find"  # two things carried one by one: said back first
        return leg

    def _delivery(self, part: str, before: list[Leg], places: PlaceIndex | None) -> Leg | None:
        """ "bring it to Q" right after a fetch is that fetch's delivery (the verbs "bring",
        "take" also start a fetch: the pronoun after a fetch decides)."""
        previous = before[-1].action if before else None
        if previous is None or previous.to is not None:
            return None
        if previous.kind != "fetch" and not (previous.kind == "find" and previous.place):
            return None  # a search in a place, then "bring it to Q": get it from there
        to = cl.deliver_slot(part, self.intents.intents["deliver"].verbs)
        put = cl.PUT_IT.match(part)
        to = to or (cl.strip_article(put["to"]) if put is not None else None)
        if to is None:
            return None
        leg = Leg(part, "deliver", Action("fetch", None, None, to), "deliver")
        return self._resolve(leg, places)

    def _non_action(self, part: str) -> Reading | None:
        """A question, greeting, stop or out-of-scope request, when it beats every action
        (by a margin when an action's verb starts the sentence)."""
        scores = self._scores(part)
        intent, score = max(scores.items(), key=lambda kv: kv[1])
        info = self.intents.intents[intent]
        if score < self.ask_threshold or info.kind == "action":
            return None
        actions = [v for k, v in scores.items() if self.intents.intents[k].kind == "action"]
        if self._verb(part) is not None and score - max(actions, default=-1.0) < 0.1:
            return None
        if intent == "resume" and self._verb(part) is not None:
            return None  # "go" alone: a drive with no place, not "go on"
        if info.kind == "refuse":
            return replace(unclear(part), intent=intent, score=score, stage="semantic")
        if info.kind == "stop":
            return Reading("stop", intent=intent, score=score, stage="semantic")
        kind: Literal["greet", "answer"] = "greet" if intent == "greet" else "answer"
        recall = default_recall() if intent == "history" else None
        return Reading(
            kind, topic=intent, intent=intent, score=score, stage="answer", recall=recall
        )

    def _scores(self, part: str) -> dict[str, float]:
        """Each intent's score: its nearest example's cosine similarity."""
        sims = self._examples @ self.embedder.embed([part])[0]
        best: dict[str, float] = {}
        for label, sim in zip(self._labels, sims.tolist(), strict=True):
            best[label] = max(best.get(label, -1.0), float(sim))
        return best

    def _verb(self, part: str) -> str | None:
        """The action intent whose verb starts ``part`` (the longest verb wins)."""
        best, length = None, 0
        for name, intent in self.intents.intents.items():
            for verb in intent.verbs if intent.kind == "action" else []:
                if (part == verb or part.startswith(verb + " ")) and len(verb) > length:
                    best, length = name, len(verb)
        return best

    def _leg(self, part: str, places: PlaceIndex | None) -> Leg:
        carried = read_roles(
            part,
            self.roles,
            lambda phrase: guards.names_a_place(places, phrase),
            lambda phrase: places is not None and places.only_place(phrase),
            _people(places),
        )
        if carried is not None:
            action = Action("fetch", carried.source, carried.thing, carried.destination)
            return self._resolve(Leg(part, action=action, intent="fetch", stage="roles"), places)
        command = parse(part)
        if command.kind != "unknown":
            kind: ActionKind = command.kind
            action = Action(kind, command.place, command.obj)
            if command.kind == "fetch":
                obj, source, to = cl.fetch_slots(part, self.intents.intents["fetch"].verbs)
                action = Action("fetch", source or command.place, obj or command.obj, to)
            return self._resolve(Leg(part, action=action, intent=command.kind), places)
        bare = cl.strip_article(re.sub(r"^(?:to|into|at)\s+", "", part))
        if places is not None and bare and places.only_place(bare):
            match = places.resolve(bare)
            return Leg(part, "bare", Action("goto", match.names[0]), "goto", near=match.near)
        near = _near_bare(places, bare)
        if near is not None:
            return Leg(part, "ambiguous", Action("goto", bare), "goto", options=near.names,
                        phrase=bare, near=True)  # fmt: skip
        scores = self._scores(part)
        ranked = sorted(scores.items(), key=lambda kv: kv[1], reverse=True)
        (intent, s1), s2 = ranked[0], ranked[1][1]
        verb = self._verb(part)
        if cl.SEARCH_IN.match(part):
            verb = "find"
        if verb is not None:
            # the verb names the intent; the meaning must not point clearly elsewhere
            own = scores.get(verb, -1.0)
            sure = own >= self.act_threshold - 0.1 and own >= s1 - 0.1
            intent, s1 = verb, max(own, s1 if verb == intent else own)
        elif not self.intents.intents[intent].verbs:
            sure = s1 >= self.act_threshold and s1 - s2 >= self.margin  # no slots (see)
        else:
            sure = False  # an action with slots but no verb we know: say it back first
        info = self.intents.intents[intent]
        leg = Leg(part, intent=intent, score=s1, sure=sure, stage="semantic")
        # a verb we know with a weak meaning is said back (asked), not refused
        if (s1 < self.ask_threshold and verb is None) or info.kind != "action":
            leg.status = "unclear"
            return leg
        verbs = info.verbs
        if intent == "goto":
            rest, _ = cl.without_verb(part, verbs)
            leg.action = Action("goto", cl.strip_article(rest) or None)
        elif intent == "find":
            obj, place = cl.find_slots(part, verbs)
            leg.action = Action("find", place, obj)
        elif intent == "fetch":
            obj, source, to = cl.fetch_slots(part, verbs)
            leg.action = Action("fetch", source, obj, to)
        elif intent == "deliver":
            to = cl.deliver_slot(part, verbs)
            leg.status, leg.action = "deliver", Action("fetch", None, None, to)
            if to is None:
                leg.status = "unclear"
            return self._resolve(leg, places) if to else leg
        elif intent == "watch":
            leg.action = Action("watch", obj=cl.watch_slot(part, verbs))
        else:
            leg.action = Action("see")
        return self._resolve(leg, places)

    def _resolve(self, leg: Leg, places: PlaceIndex | None) -> Leg:
        """Fill missing-slot status, and turn place phrases into the live places' names."""
        action = leg.action
        assert action is not None
        if action.kind in ("find", "fetch", "watch") and not action.obj and leg.status == "ok":
            leg.status, leg.slot = "missing", "obj"
            return leg
        if action.kind in ("goto", "fetch") and not action.place and leg.status == "ok":
            leg.status, leg.slot = "missing", "place"  # its destination is resolved still
        if places is None:
            return leg
        for slot in ("place", "to"):
            phrase = getattr(action, slot)
            if not phrase:
                continue
            match = places.resolve(phrase)
            leg.near = leg.near or match.near
            if match.sure:
                action = _with(action, slot, match.names[0])
                continue
            leg.slot = "place" if slot == "place" else "to"
            leg.phrase = cl.strip_article(phrase)
            if match.names:
                leg.status = "ambiguous"
            else:  # a place name is never a whole unparsed sentence ("how is your battery")
                leg.status = "unknown_place" if could_name_a_place(leg.phrase) else "unclear"
            leg.options = match.names
            break
        leg.action = action
        return leg

    # --- the answer to a question we asked --------------------------------------------------
    def follow_up(
        self, question: Question, answer: str, places: PlaceIndex | None
    ) -> Reading | None:
        """The request completed by ``answer``; a cancel; or None (not an answer: read it as a
        new request)."""
        reading = follow_up(question, answer, places)
        return check_answer(reading, places) if reading is not None else None


def _people(places: PlaceIndex | None) -> set[str]:
    """Whose places the map names ("Alice's desk" → alice), not places themselves."""
    return {o for o in places.owners() if places.get(o) is None} if places is not None else set()


def _near_bare(places: PlaceIndex | None, bare: str) -> PlaceMatch | None:
    """A part that is only a place said a little wrong ("the reciption"), unsure: asked."""
    if places is None or not bare or len(bare.split()) > 3:
        return None
    match = places.resolve(bare)
    return match if match.near and match.names and not match.sure else None
