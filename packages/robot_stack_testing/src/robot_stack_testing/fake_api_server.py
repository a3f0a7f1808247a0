"""Run a local fake HTTP API (aiohttp) on a free loopback port in a background thread.

Used by the strict fakes of the model APIs so that sync tests, async tests and subprocesses
under test can all reach them. Stopped on exit of the context manager, also on failure.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from aiohttp import web

from robot_stack_testing.ports import free_tcp_port


@contextmanager
def serve_in_thread(app: web.Application, timeout_s: float = 10.0) -> Iterator[str]:
    """Serve ``app`` on 127.0.0.1:<free port>; yields the base URL (``http://127.0.0.1:N``)."""
    port = free_tcp_port()
    loop = asyncio.new_event_loop()
    started = threading.Event()
    failure: list[BaseException] = []
    runner = web.AppRunner(app, access_log=None)

    async def start() -> None:
        await runner.setup()
        await web.TCPSite(runner, "127.0.0.1", port).start()

    def run() -> None:
        asyncio.set_event_loop(loop)
        try:
            loop.run_until_complete(start())
        except BaseException as exc:  # reported to the caller below
            failure.append(exc)
            started.set()
            return
        started.set()
        loop.run_forever()
        loop.run_until_complete(runner.cleanup())
        loop.close()

    thread = threading.Thread(target=run, name=f"fake-api-{port}", daemon=True)
    thread.start()
    if not started.wait(timeout_s) or failure:
        raise RuntimeError(f"fake API did not start on port {port}: {failure}")
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout_s)
