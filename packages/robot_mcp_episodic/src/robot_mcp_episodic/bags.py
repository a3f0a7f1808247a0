"""Raw recording as rosbag2-compatible MCAP: one bag directory per rotation period
(``<dir>/bags/episodic_<UTC start>/``) with its ``.mcap`` file and the ``metadata.yaml`` that
``ros2 bag info``, ``rosbags`` and Foxglove read. Messages are stored as the CDR bytes that
arrived (``ros2msg`` schemas, ``cdr`` encoding, zstd chunks).

``flush()`` (called every flush interval) writes the open chunk to the file; a bag left open by
a crash (no ``metadata.yaml``) is repaired at start-up: every flushed message is copied into
a finished file. Retention and the size cap delete whole bags, oldest first; ``forget``
rewrites the bags it touches without the forgotten messages.
"""

from __future__ import annotations

import shutil
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import structlog
import yaml
from mcap.reader import NonSeekingReader, make_reader
from mcap.writer import CompressionType, Writer

from robot_mcp_episodic.msgdefs import message_definition

logger = structlog.get_logger(__name__)

METADATA = "metadata.yaml"
ROSBAG2_VERSION = 9
ROS_DISTRO = "kilted"

# Decides per message whether forget removes it: (topic, log_time_ns, cdr bytes) -> bool.
Selector = Callable[[str, int, bytes], bool]


@dataclass
class _TopicCount:
    type_name: str
    count: int = 0


@dataclass
class _OpenBag:
    path: Path
    file: IO[bytes]
    writer: Writer
    started_ns: int
    schemas: dict[str, int] = field(default_factory=dict)
    channels: dict[str, int] = field(default_factory=dict)
    topics: dict[str, _TopicCount] = field(default_factory=dict)
    first_ns: int | None = None
    last_ns: int = 0
    count: int = 0
    flushed: int = 0  # messages written to the file at the last flush (what a crash keeps)


@dataclass(frozen=True)
class BagInfo:
    path: Path
    start: float
    end: float
    messages: int
    size_bytes: int
    open: bool
    on_disk: int  # messages a crash now would keep (an open bag's last flush)


def _bag_name(stamp_ns: int) -> str:
    return "episodic_" + datetime.fromtimestamp(stamp_ns / 1e9, UTC).strftime("%Y%m%dT%H%M%SZ")


class BagRecorder:
    def __init__(self, root: Path, rotate_s: float = 3600.0) -> None:
        self.root = root / "bags"
        self.root.mkdir(parents=True, exist_ok=True)
        self._rotate_ns = int(rotate_s * 1e9)
        self._lock = threading.Lock()
        self._bag: _OpenBag | None = None
        self.written = 0
        self.repaired = self._repair_unfinished()

    # -- writing -----------------------------------------------------------------------------
    def write(self, topic: str, type_name: str, data: bytes, stamp_ns: int | None = None) -> None:
        """Append one serialized (CDR) message; rotates to a new bag every ``rotate_s``."""
        stamp = time.time_ns() if stamp_ns is None else stamp_ns
        with self._lock:
            bag = self._bag
            if bag is None or stamp - bag.started_ns >= self._rotate_ns:
                if bag is not None:
                    self._finish(bag)
                bag = self._bag = self._open(stamp)
            channel = bag.channels.get(topic)
            if channel is None:
                channel = self._channel(bag, topic, type_name)
            bag.writer.add_message(
                channel, log_time=stamp, data=data, publish_time=stamp, sequence=bag.count
            )
            bag.count += 1
            bag.topics[topic].count += 1
            bag.first_ns = stamp if bag.first_ns is None else min(bag.first_ns, stamp)
            bag.last_ns = max(bag.last_ns, stamp)
            self.written += 1

    def _open(self, stamp_ns: int) -> _OpenBag:
        name = _bag_name(stamp_ns)
        path = self.root / name
        suffix = 1
        while path.exists():
            path = self.root / f"{name}-{suffix}"
            suffix += 1
        path.mkdir(parents=True)
        handle = (path / f"{path.name}_0.mcap").open("wb")
        writer = Writer(handle, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="robot-mcp-episodic")
        logger.info("episodic_bag_opened", bag=str(path))
        return _OpenBag(path, handle, writer, stamp_ns)

    def _channel(self, bag: _OpenBag, topic: str, type_name: str) -> int:
        schema = bag.schemas.get(type_name)
        if schema is None:
            schema = bag.writer.register_schema(
                type_name, "ros2msg", message_definition(type_name).encode()
            )
            bag.schemas[type_name] = schema
        channel = bag.writer.register_channel(
            topic, "cdr", schema, metadata={"offered_qos_profiles": ""}
        )
        bag.channels[topic] = channel
        bag.topics[topic] = _TopicCount(type_name)
        return channel

    def flush(self) -> None:
        """Write the open chunk to the file (what a crash can lose is what came after)."""
        with self._lock:
            if self._bag is not None:
                self._bag.writer.flush()  # type: ignore[no-untyped-call]
                self._bag.flushed = self._bag.count

    def close(self) -> None:
        with self._lock:
            if self._bag is not None:
                self._finish(self._bag)
                self._bag = None

    def _finish(self, bag: _OpenBag) -> None:
        bag.writer.finish()  # type: ignore[no-untyped-call]
        bag.file.close()
        _write_metadata(bag.path)
        logger.info("episodic_bag_closed", bag=str(bag.path), messages=bag.count)

    # -- reading, retention, forgetting ------------------------------------------------------
    def bags(self) -> list[BagInfo]:
        with self._lock:
            open_path = self._bag.path if self._bag else None
            infos = []
            for path in sorted(p for p in self.root.iterdir() if p.is_dir()):
                size = sum(f.stat().st_size for f in path.iterdir() if f.is_file())
                if path == open_path and self._bag is not None:
                    bag = self._bag
                    first = bag.first_ns or bag.started_ns
                    span = (first / 1e9, bag.last_ns / 1e9)
                    infos.append(BagInfo(path, *span, bag.count, size, True, bag.flushed))
                    continue
                meta = _read_metadata(path)
                if meta is None:
                    continue
                start = meta["starting_time"]["nanoseconds_since_epoch"] / 1e9
                end = start + meta["duration"]["nanoseconds"] / 1e9
                count = meta["message_count"]
                infos.append(BagInfo(path, start, end, count, size, False, count))
            return infos

    def size_bytes(self) -> int:
        return sum(bag.size_bytes for bag in self.bags())

    def delete_before(self, before: float) -> list[Path]:
        """Delete finished bags whose last message is older than ``before``."""
        return self._delete([b for b in self.bags() if not b.open and b.end < before])

    def delete_oldest(self) -> Path | None:
        finished = [b for b in self.bags() if not b.open]
        deleted = self._delete(finished[:1])
        return deleted[0] if deleted else None

    def _delete(self, bags: Iterable[BagInfo]) -> list[Path]:
        deleted = []
        with self._lock:
            for bag in bags:
                shutil.rmtree(bag.path, ignore_errors=True)
                deleted.append(bag.path)
                logger.info("episodic_bag_deleted", bag=str(bag.path))
        return deleted

    def forget(self, start: float, end: float, selector: Selector, *, dry_run: bool) -> int:
        """Remove (or with ``dry_run`` count) the messages in ``[start, end]`` that
        ``selector`` picks, rewriting every bag that holds one. The open bag is closed first
        (recording continues in a new one)."""
        if not dry_run:
            self.close()
        removed = 0
        for bag in self.bags():
            if bag.end < start or bag.start > end:
                continue
            if bag.open:
                removed += self._count_open(start, end, selector)
                continue
            removed += _rewrite(bag.path, start, end, selector, dry_run=dry_run)
        return removed

    def _count_open(self, start: float, end: float, selector: Selector) -> int:
        self.flush()
        with self._lock:
            assert self._bag is not None
            mcap = next(self._bag.path.glob("*.mcap"))
        return sum(1 for m in _messages(mcap) if _picked(m, start, end, selector))

    def _repair_unfinished(self) -> list[Path]:
        repaired = []
        for path in sorted(p for p in self.root.iterdir() if p.is_dir()):
            if (path / METADATA).exists():
                continue
            files = list(path.glob("*.mcap"))
            if not files:
                shutil.rmtree(path, ignore_errors=True)
                continue
            _rewrite(path, 0.0, 0.0, lambda *_: False, dry_run=False)
            repaired.append(path)
            logger.warning("episodic_bag_repaired", bag=str(path))
        return repaired


def _messages(mcap: Path) -> list[tuple[Any, Any, Any]]:
    """Every readable message (schema, channel, message); a file a crash cut short is read
    up to its last complete chunk."""
    found: list[tuple[Any, Any, Any]] = []
    with mcap.open("rb") as handle:
        try:
            reader = make_reader(handle)
            found.extend(reader.iter_messages(log_time_order=False))
            return found
        except Exception:  # no summary or a cut-off tail: stream what is there
            found.clear()
        handle.seek(0)
        try:
            found.extend(NonSeekingReader(handle).iter_messages(log_time_order=False))
        except Exception as exc:
            logger.warning("episodic_bag_truncated", file=str(mcap), error=str(exc))
    return found


def _picked(item: tuple[Any, Any, Any], start: float, end: float, selector: Selector) -> bool:
    _schema, channel, message = item
    return bool(
        start * 1e9 <= message.log_time <= end * 1e9
        and selector(channel.topic, message.log_time, message.data)
    )


def _rewrite(path: Path, start: float, end: float, selector: Selector, *, dry_run: bool) -> int:
    files = sorted(path.glob("*.mcap"))
    items = [item for mcap in files for item in _messages(mcap)]
    keep = [item for item in items if not _picked(item, start, end, selector)]
    removed = len(items) - len(keep)
    if dry_run or (removed == 0 and (path / METADATA).exists()):
        return removed
    target = path / f"{path.name}_0.mcap"
    scratch = path / f"{path.name}.rewrite"
    with scratch.open("wb") as handle:
        writer = Writer(handle, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="robot-mcp-episodic")
        schemas: dict[str, int] = {}
        channels: dict[str, int] = {}
        for schema, channel, message in sorted(keep, key=lambda item: item[2].log_time):
            if schema.name not in schemas:
                schemas[schema.name] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.topic not in channels:
                channels[channel.topic] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.name],
                    metadata=dict(channel.metadata),
                )  # fmt: skip
            writer.add_message(
                channels[channel.topic], log_time=message.log_time, data=message.data,
                publish_time=message.publish_time, sequence=message.sequence,
            )  # fmt: skip
        writer.finish()  # type: ignore[no-untyped-call]
    for old in files:
        old.unlink()
    scratch.rename(target)
    _write_metadata(path)
    return removed


def _write_metadata(path: Path) -> None:
    """The rosbag2 ``metadata.yaml`` of a finished bag directory (read from its MCAP)."""
    files = []
    topics: dict[str, dict[str, Any]] = {}
    first: int | None = None
    last = 0
    total = 0
    for mcap in sorted(path.glob("*.mcap")):
        file_first: int | None = None
        file_last = 0
        count = 0
        for schema, channel, message in _messages(mcap):
            entry = topics.setdefault(channel.topic, {"type": schema.name, "count": 0})
            entry["count"] += 1
            count += 1
            file_first = (
                message.log_time if file_first is None else min(file_first, message.log_time)
            )
            file_last = max(file_last, message.log_time)
        file_first = file_first or 0
        files.append({
            "path": mcap.name,
            "starting_time": {"nanoseconds_since_epoch": file_first},
            "duration": {"nanoseconds": max(0, file_last - file_first)},
            "message_count": count,
        })  # fmt: skip
        total += count
        if count:
            first = file_first if first is None else min(first, file_first)
            last = max(last, file_last)
    start = first or 0
    info = {
        "version": ROSBAG2_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": max(0, last - start)},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": total,
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": topic,
                    "type": entry["type"],
                    "serialization_format": "cdr",
                    "offered_qos_profiles": [],
                    "type_description_hash": "",
                },
                "message_count": entry["count"],
            }
            for topic, entry in sorted(topics.items())
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [f["path"] for f in files],
        "files": files,
        "custom_data": {},
        "ros_distro": ROS_DISTRO,
    }
    text = yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False)
    scratch = path / f"{METADATA}.tmp"
    scratch.write_text(text, encoding="utf-8")
    scratch.rename(path / METADATA)


def _read_metadata(path: Path) -> dict[str, Any] | None:
    try:
        data = yaml.safe_load((path / METADATA).read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError):
        return None
    info = data.get("rosbag2_bagfile_information") if isinstance(data, dict) else None
    return info if isinstance(info, dict) else None
