"""A poster in its own OS process: emits events for a few tasks until killed.

After each emit() returns (the event is durable) it prints ``EMITTED <event_id> <task_id> <seq>``.
argv: url secret outbox_path tasks interval_s
"""

from __future__ import annotations

import asyncio
import sys

from robot_mcp_kit.poster import EventPoster


async def main(url: str, secret: str, outbox: str, tasks: int, interval_s: float) -> None:
    async with EventPoster(
        url, "navigation", secret, outbox, backoff_initial_s=0.02, backoff_max_s=0.3
    ) as poster:
        i = 0
        while True:
            event = await poster.emit(f"proc-{i % tasks}", "navigate_to", "progress", {"i": i})
            sys.stdout.write(f"EMITTED {event.event_id} {event.task_id} {event.seq}\n")
            sys.stdout.flush()
            i += 1
            await asyncio.sleep(interval_s)


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5])))
