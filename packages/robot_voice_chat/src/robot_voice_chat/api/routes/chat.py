"""REST twin of the Socket.IO chat: text turns, audio turns (SpeechInput), stop."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, Request

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.services.speech.base import TranscriptionError
from robot_voice_chat.socket_events import SendMessage

router = APIRouter(prefix="/api/chat", tags=["chat"])
MAX_AUDIO_BYTES = 10 * 1024 * 1024
BODY_LIMITS = {"/api/chat/audio": MAX_AUDIO_BYTES}  # above api.max_body_bytes (BodyLimit)


@router.post("", operation_id="send_message")
async def send_message(body: SendMessage, container: ContainerDep) -> dict[str, Any]:
    result = await container.pipeline.handle_turn(body.text)
    return {
        "turn_id": result.turn_id,
        "reply": result.reply,
        "route": result.route,
        "mission_id": result.mission_id,
    }


@router.post("/audio", operation_id="send_audio")
async def send_audio(request: Request, container: ContainerDep) -> dict[str, Any]:
    mime = request.headers.get("content-type", "")
    if not mime.startswith("audio/"):
        raise HTTPException(415, "send the recording as the raw body with an audio/* content type")
    audio = await request.body()
    if not audio or len(audio) > MAX_AUDIO_BYTES:
        raise HTTPException(413 if audio else 400, "audio must be 1 byte .. 10 MiB")
    try:
        text = await container.adapters.speech_input.transcribe(audio, mime)
    except TranscriptionError as exc:
        raise HTTPException(422, str(exc)) from exc
    if not text.strip():
        raise HTTPException(422, "nothing was said")
    result = await container.pipeline.handle_turn(text)
    return {
        "transcript": text,
        "turn_id": result.turn_id,
        "reply": result.reply,
        "route": result.route,
    }


@router.post("/stop", operation_id="stop_pipeline")
async def stop(container: ContainerDep) -> dict[str, str]:
    await container.pipeline.stop()
    return {"status": "stopped"}
