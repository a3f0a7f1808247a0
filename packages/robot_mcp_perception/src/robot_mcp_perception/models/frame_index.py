"""Index of annotated frames, found again by *content* (whatever delivered the image).

Each annotation JSON (the ``sample_scenes`` format) sits next to its frame image. At load
time every frame is kept as a small grayscale thumbnail (full-frame lookup) and a
``SEARCH_WIDTH``-px grayscale copy (crop lookup). :meth:`FrameIndex.locate` answers "which
stored frame, and which window of it, is this image?":

1. full frame — cosine similarity of zero-mean 64×48 grayscale thumbnails at least
   ``full_threshold`` (0.95; the same frame resized and JPEG-compressed scores > 0.99, two
   different sample scenes < 0.75); works for any resize of the frame (e.g. a camera topic
   at another resolution);
2. crop (a segment_all tile) — ``cv2.matchTemplate`` (normalised correlation) of the
   downscaled image inside each stored frame, at a few frame scales (1, 1/2, 3/4, 4/3, 2),
   most recently matched frame first; accepted above ``crop_threshold``.

Frames added to the folder while the node runs are picked up (:meth:`FrameIndex.refresh`,
called before every lookup): when the folder's modification time changed, annotation files
not indexed yet are loaded, and frames whose annotation file is gone are dropped (a producer
that keeps a bounded folder — ``robot-sim`` renders a new frame whenever the robot moves and
keeps the newest few dozen — bounds the index too). A producer writes the image first and the
JSON last, each by rename, so a JSON present means its image is complete, and deletes the
JSON first. Only files directly in a watched folder change its mtime: new frames belong in the
top folder, not in new subfolders.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_mcp_perception.models.base import Image, ModelUnavailableError

THUMB_SIZE = (64, 48)
SEARCH_WIDTH = 160
CROP_SCALES = (1.0, 0.5, 0.75, 4 / 3, 2.0)

FloatArray = npt.NDArray[np.float32]


@dataclass(frozen=True)
class AnnotatedObject:
    id: int
    label: str
    polygons: list[npt.NDArray[np.float64]]
    """Polygons in stored-frame pixels, each (N, 2) x/y."""
    area: float
    difficulty: str = "easy"


@dataclass(frozen=True)
class AnnotatedFrame:
    path: Path
    width: int
    height: int
    description: str
    objects: list[AnnotatedObject]
    thumb: FloatArray
    search: FloatArray
    gray: Any
    """Full-resolution grayscale, for pixel-exact refinement of crop matches."""
    annotation: Path | None = None
    """The annotation file it was read from."""


@dataclass(frozen=True)
class Located:
    frame: AnnotatedFrame
    window: tuple[float, float, float, float]
    """The image's extent in stored-frame pixels (x0, y0, x1, y1)."""
    score: float
    """Full-frame: thumbnail cosine similarity; crop: normalised correlation."""


def _gray(image: Image) -> Any:
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def _thumb(gray: Any) -> FloatArray:
    """Zero-mean, unit-norm thumbnail (all zeros for a flat image)."""
    small = np.asarray(cv2.resize(gray, THUMB_SIZE, interpolation=cv2.INTER_AREA), np.float32)
    small -= small.mean()
    norm = float(np.linalg.norm(small))
    return small / norm if norm > 1e-3 else np.zeros_like(small)


def _parse_objects(doc: dict[str, Any], source: Path) -> list[AnnotatedObject]:
    objects: list[AnnotatedObject] = []
    for ann in doc.get("annotations", []):
        try:
            polys = [np.asarray(p, np.float64).reshape(-1, 2) for p in ann["segmentation"]]
            if not polys:
                x, y, w, h = ann["bbox"]
                polys = [np.asarray([(x, y), (x + w, y), (x + w, y + h), (x, y + h)], np.float64)]
            area = float(
                ann.get("area") or sum(cv2.contourArea(p.astype(np.float32)) for p in polys)
            )
            objects.append(
                AnnotatedObject(
                    int(ann.get("id", len(objects) + 1)),
                    str(ann["label"]),
                    polys,
                    max(area, 1.0),
                    str(ann.get("difficulty", "easy")),
                )
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{source}: bad annotation {ann!r}: {exc}") from exc
    return objects


def load_frame(json_path: Path) -> AnnotatedFrame:
    doc = json.loads(json_path.read_text())
    image_path = json_path.with_name(doc["image"]["file_name"])
    bgr = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"{json_path}: frame image {image_path} is missing or unreadable")
    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    height, width = gray.shape
    search_h = max(1, round(height * SEARCH_WIDTH / width))
    search = cv2.resize(gray, (SEARCH_WIDTH, search_h), interpolation=cv2.INTER_AREA)
    return AnnotatedFrame(
        image_path,
        width,
        height,
        str(doc.get("description", "")),
        _parse_objects(doc, json_path),
        _thumb(gray),
        np.asarray(search, np.float32),
        gray,
        json_path,
    )


class FrameIndex:
    def __init__(
        self,
        frames: list[AnnotatedFrame],
        full_threshold: float = 0.95,
        crop_threshold: float = 0.8,
        directory: Path | None = None,
        known: set[Path] | None = None,
    ) -> None:
        self.frames = frames
        self.full_threshold = full_threshold
        self.crop_threshold = crop_threshold
        self.directory = directory
        self._last_hit = 0
        self._lock = threading.Lock()
        self._known = set(known or ())
        """Every JSON file of the folder already read (annotations or not)."""
        self._mtime_ns = _mtime_ns(directory)

    @classmethod
    def load(cls, directory: Path, **kwargs: float) -> FrameIndex:
        if not directory.is_dir():
            raise ModelUnavailableError(
                f"annotation directory {directory} does not exist; generate sample scenes with "
                f"`python -m robot_mcp_perception.sample_scenes {directory}`"
            )
        mtime_ns = _mtime_ns(directory)
        known: set[Path] = set()
        frames = _load_new(directory, known, strict=True)
        if not frames:
            raise ModelUnavailableError(
                f"no annotated frames (image + annotation JSON) in {directory}; generate them "
                f"with `python -m robot_mcp_perception.sample_scenes {directory}`"
            )
        index = cls(frames, directory=directory, known=known, **kwargs)
        index._mtime_ns = mtime_ns  # anything written during the load is read on refresh
        return index

    def refresh(self) -> int:
        """Index the frames added to the folder since the last look; how many were added."""
        if self.directory is None:
            return 0
        with self._lock:
            mtime_ns = _mtime_ns(self.directory)
            if mtime_ns == self._mtime_ns:
                return 0
            self._mtime_ns = mtime_ns
            present = set(self.directory.rglob("*.json"))
            gone = self._known - present
            if gone:
                self._known -= gone
                kept = [f for f in self.frames if f.annotation not in gone]
                self._last_hit = 0 if len(kept) != len(self.frames) else self._last_hit
                self.frames = kept
            added = _load_new(self.directory, self._known, strict=False)
            self.frames = [*self.frames, *added]
            return len(added)

    def locate(self, image: Image) -> Located | None:
        self.refresh()
        gray = _gray(image)
        if float(gray.std()) < 1.0:
            return None  # a flat image matches nothing
        full = self._locate_full(gray)
        return full if full is not None else self._locate_crop(gray)

    def _order(self) -> list[int]:
        return [self._last_hit, *(i for i in range(len(self.frames)) if i != self._last_hit)]

    def _locate_full(self, gray: Any) -> Located | None:
        h, w = gray.shape
        thumb = _thumb(gray)
        best: tuple[float, int] | None = None
        for i in self._order():
            frame = self.frames[i]
            if abs(w / h - frame.width / frame.height) > 0.03:
                continue
            score = float(np.sum(thumb * frame.thumb))
            if best is None or score > best[0]:
                best = (score, i)
        if best is None or best[0] < self.full_threshold:
            return None
        self._last_hit = best[1]
        frame = self.frames[best[1]]
        return Located(frame, (0.0, 0.0, float(frame.width), float(frame.height)), best[0])

    def _locate_crop(self, gray: Any) -> Located | None:
        h, w = gray.shape
        best: tuple[float, int, float, tuple[int, int], tuple[int, int]] | None = None
        for i in self._order():
            frame = self.frames[i]
            k = SEARCH_WIDTH / frame.width
            sh, sw = frame.search.shape
            for scale in CROP_SCALES:
                tw, th = round(w / scale * k), round(h / scale * k)
                if tw < 12 or th < 12 or tw > sw or th > sh or (tw == sw and th == sh):
                    continue
                template = cv2.resize(gray, (tw, th), interpolation=cv2.INTER_AREA)
                scores = cv2.matchTemplate(
                    frame.search, np.asarray(template, np.float32), cv2.TM_CCOEFF_NORMED
                )
                _, score, _, loc = cv2.minMaxLoc(scores)
                if best is None or score > best[0]:
                    best = (float(score), i, k, (int(loc[0]), int(loc[1])), (tw, th))
            if best is not None and best[0] >= 0.97:
                break
        if best is None or best[0] < self.crop_threshold:
            return None
        score, i, k, (lx, ly), (tw, th) = best
        self._last_hit = i
        frame = self.frames[i]
        window = (lx / k, ly / k, (lx + tw) / k, (ly + th) / k)
        if abs(tw / k - w) <= 1 / k + 1 and abs(th / k - h) <= 1 / k + 1:
            window = self._refine(frame, gray, (round(lx / k), round(ly / k)), round(1 / k) + 2)
        return Located(frame, window, score)

    @staticmethod
    def _refine(
        frame: AnnotatedFrame, gray: Any, guess: tuple[int, int], reach: int
    ) -> tuple[float, float, float, float]:
        """Pixel-exact position of a same-scale crop near ``guess`` in the full-res frame."""
        h, w = gray.shape
        x0, y0 = max(0, guess[0] - reach), max(0, guess[1] - reach)
        x1 = min(frame.width, guess[0] + w + reach)
        y1 = min(frame.height, guess[1] + h + reach)
        region = frame.gray[y0:y1, x0:x1]
        if region.shape[0] < h or region.shape[1] < w:
            gx, gy = guess
        else:
            scores = cv2.matchTemplate(region, gray, cv2.TM_CCOEFF_NORMED)
            _, _, _, loc = cv2.minMaxLoc(scores)
            gx, gy = x0 + int(loc[0]), y0 + int(loc[1])
        return float(gx), float(gy), float(gx + w), float(gy + h)


def _mtime_ns(directory: Path | None) -> int:
    try:
        return directory.stat().st_mtime_ns if directory is not None else 0
    except OSError:
        return 0


def _load_new(directory: Path, known: set[Path], strict: bool) -> list[AnnotatedFrame]:
    """The annotated frames of ``directory`` whose JSON is not in ``known`` (updated).

    ``strict``: a frame whose image is missing raises (start-up); otherwise it is skipped
    and read again on the next change of the folder.
    """
    frames = []
    for json_path in sorted(directory.rglob("*.json")):
        if json_path in known:
            continue
        try:
            doc = json.loads(json_path.read_text())
        except (OSError, ValueError):
            known.add(json_path)
            continue
        if not (isinstance(doc, dict) and "image" in doc and "annotations" in doc):
            known.add(json_path)
            continue
        try:
            frames.append(load_frame(json_path))
        except (OSError, ValueError, KeyError):
            if strict and json_path.exists():  # gone meanwhile: its producer deleted it
                raise
            continue
        known.add(json_path)
    return frames
