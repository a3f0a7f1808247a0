"""REST twin of the Socket.IO chat: text turns, audio turns (SpeechInput), stop."""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any

from fastapi import APIRouter, HTTPException, Request

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.pipeline.spoken import SpokenResult, SpokenTurns
from robot_voice_chat.services.speech.audio import AudioFormatError, UnsupportedAudio, decode
from robot_voice_chat.services.speech.base import TranscriptionError

if TYPE_CHECKING:
    from robot_voice_chat.api.container import Container
from robot_voice_chat.socket_events import SendMessage

router = APIRouter(prefix="/api/chat", tags=["chat"])
MAX_AUDIO_BYTES = 10 * 1024 * 1024
BODY_LIMITS = {"/api/chat/audio": MAX_AUDIO_BYTES}  # above api.max_body_bytes (BodyLimit)
SOURCES = ("browser", "microphone")


@router.post("", operation_id="send_message")
async def send_message(body: SendMessage, container: ContainerDep) -> dict[str, Any]:
    result = await container.pipeline.handle_turn(body.text)
    return {
        "turn_id": result.turn_id,
        "reply": result.reply,
        "route": result.route,
        "mission_id": result.mission_id,
    }


def spoken_turns(request: Request, container: Container) -> SpokenTurns:
    """The app's one :class:`SpokenTurns` (made on first use; it keeps a pending read-back)."""
    spoken: SpokenTurns | None = getattr(request.app.state, "spoken_turns", None)
    if spoken is None:
        spoken = SpokenTurns(
            speech_input=container.adapters.speech_input,
            pipeline=container.pipeline,
            tools=container.adapters.tools,
            emitter=container.emitter,
            speech_output=container.adapters.speech_output,
            wake_phrase=container.config.chat.wake_phrase,
        )
        request.app.state.spoken_turns = spoken
    return spoken


def spoken_answer(result: SpokenResult) -> dict[str, Any]:
    """``POST /api/chat``'s fields plus what was heard."""
    heard, turn = result.heard, result.turn
    return {
        "transcript": heard.text,
        "confidence": heard.confidence,
        "recognizer": heard.engine,
        "heard": heard.kind,
        "rejected": heard.rejected,
        "read_back": result.read_back,
        "addressed": result.addressed,
        "turn_id": turn.turn_id if turn else None,
        "reply": turn.reply if turn else result.reply,
        "route": turn.route if turn else "heard",
        "mission_id": turn.mission_id if turn else None,
    }


@router.post("/audio", operation_id="send_audio")
async def send_audio(request: Request, container: ContainerDep) -> dict[str, Any]:
    """A recording (raw body, its content type) → heard → a turn like ``POST /api/chat``.
    ``?source=microphone``: the robot's own microphone (``chat.wake_phrase`` applies; the
    default ``browser`` is push-to-talk). 415: not an audio type the brain decodes; 422: not
    decodable, the recognizer failed, or an unknown source."""
    source = request.query_params.get("source", "browser")
    if source not in SOURCES:
        raise HTTPException(422, f"source must be one of {', '.join(SOURCES)}")
    mime = request.headers.get("content-type", "")
    if not mime.startswith("audio/"):
        raise HTTPException(415, "send the recording as the raw body with an audio/* content type")
    audio = await request.body()
    if not audio or len(audio) > MAX_AUDIO_BYTES:
        raise HTTPException(413 if audio else 400, "audio must be 1 byte .. 10 MiB")
    if not container.adapters.speech_input.configured:
        raise HTTPException(422, "no speech input configured (speech_input: none)")
    try:
        utterance = await asyncio.to_thread(decode, audio, mime)
    except UnsupportedAudio as exc:
        raise HTTPException(415, str(exc)) from exc
    except AudioFormatError as exc:
        raise HTTPException(422, str(exc)) from exc
    try:
        result = await spoken_turns(request, container).hear(
            utterance, from_microphone=source == "microphone"
        )
    except TranscriptionError as exc:
        raise HTTPException(422, str(exc)) from exc
    return spoken_answer(result)


@router.post("/stop", operation_id="stop_pipeline")
async def stop(container: ContainerDep) -> dict[str, str]:
    await container.pipeline.stop()
    return {"status": "stopped"}
