"""Geometry of segment_all: tiles, tile → full-image mapping, merging, dedupe and NMS."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from robot_mcp_perception.models.base import Box, GroundedTarget, Point


@dataclass(frozen=True)
class Tile:
    box: Box
    """The tile in full-image pixels (x0, y0, x1, y1)."""

    def interior_sides(self, width: int, height: int) -> frozenset[str]:
        """Sides of the tile that are not on the image border."""
        x0, y0, x1, y1 = self.box
        sides = {"left": x0 > 0, "top": y0 > 0, "right": x1 < width, "bottom": y1 < height}
        return frozenset(k for k, v in sides.items() if v)


@dataclass(frozen=True)
class MappedTarget:
    """A pointing answer in full-image pixels, with the tile it came from."""

    target: GroundedTarget
    tile: int
    truncated: frozenset[str] = field(default_factory=frozenset)
    """Tile sides (interior ones only) that cut the target's box."""

    @property
    def score(self) -> float:
        return self.target.confidence if self.target.confidence is not None else 1.0


def make_tiles(width: int, height: int, grid: tuple[int, int], overlap: float) -> list[Tile]:
    """``grid`` = (columns, rows); each tile grows by ``overlap`` × its size into neighbours."""
    cols, rows = grid
    if cols < 1 or rows < 1:
        raise ValueError(f"tile_grid must be at least (1, 1), got {grid}")
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"tile_overlap must be in [0, 1), got {overlap}")
    sx, sy = width / cols, height / rows
    tiles = []
    for r in range(rows):
        for c in range(cols):
            tiles.append(
                Tile(
                    (
                        max(0, round(c * sx - overlap * sx)),
                        max(0, round(r * sy - overlap * sy)),
                        min(width, round((c + 1) * sx + overlap * sx)),
                        min(height, round((r + 1) * sy + overlap * sy)),
                    )
                )
            )
    return tiles


def to_full_image(
    target: GroundedTarget, tile_index: int, tile: Tile, width: int, height: int, edge_px: int = 2
) -> MappedTarget:
    """Map a target found in ``tile`` (tile pixels) to full-image pixels."""
    tx0, ty0, tx1, ty1 = tile.box
    tw, th = tx1 - tx0, ty1 - ty0
    box = None
    truncated: set[str] = set()
    if target.box is not None:
        bx0, by0, bx1, by1 = target.box
        interior = tile.interior_sides(width, height)
        cut = {
            "left": bx0 <= edge_px,
            "top": by0 <= edge_px,
            "right": bx1 >= tw - edge_px,
            "bottom": by1 >= th - edge_px,
        }
        truncated = {side for side, hit in cut.items() if hit and side in interior}
        box = (bx0 + tx0, by0 + ty0, bx1 + tx0, by1 + ty0)
    points = [(x + tx0, y + ty0) for x, y in target.points]
    return MappedTarget(replace(target, box=box, points=points), tile_index, frozenset(truncated))


def box_iou(a: Box, b: Box) -> float:
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def _touch(a: Box, b: Box, gap: int = 2) -> bool:
    return a[0] <= b[2] + gap and b[0] <= a[2] + gap and a[1] <= b[3] + gap and b[1] <= a[3] + gap


def merge_truncated(targets: list[MappedTarget]) -> list[MappedTarget]:
    """Join pieces of one object cut by tile borders: same label, boxes touching or
    overlapping, from different tiles, at least one cut by an interior tile side. The merged
    box is the union; label, point and confidence come from the best-scored piece."""
    parent = list(range(len(targets)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, a in enumerate(targets):
        for j in range(i + 1, len(targets)):
            b = targets[j]
            if (
                a.tile != b.tile
                and (a.truncated or b.truncated)
                and a.target.box is not None
                and b.target.box is not None
                and a.target.label.lower() == b.target.label.lower()
                and _touch(a.target.box, b.target.box)
            ):
                parent[find(i)] = find(j)
    groups: dict[int, list[MappedTarget]] = {}
    for i, t in enumerate(targets):
        groups.setdefault(find(i), []).append(t)
    merged = []
    for members in groups.values():
        if len(members) == 1:
            merged.append(members[0])
            continue
        best = max(members, key=lambda m: m.score)
        boxes = [m.target.box for m in members if m.target.box is not None]
        union = (
            min(b[0] for b in boxes),
            min(b[1] for b in boxes),
            max(b[2] for b in boxes),
            max(b[3] for b in boxes),
        )
        merged.append(
            MappedTarget(
                replace(best.target, box=union),
                best.tile,
                frozenset().union(*(m.truncated for m in members)),
            )
        )
    return merged


def dedupe_points(targets: list[MappedTarget], radius_px: float) -> list[MappedTarget]:
    """Drop targets whose point lies within ``radius_px`` of a better-scored kept target."""
    kept: list[MappedTarget] = []
    for t in sorted(targets, key=lambda m: -m.score):
        p = _point(t)
        if p is not None and any(
            (q := _point(k)) is not None and (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 <= radius_px**2
            for k in kept
        ):
            continue
        kept.append(t)
    return kept


def nms(targets: list[MappedTarget], iou_threshold: float) -> list[MappedTarget]:
    """Confidence NMS on boxes; targets without a box are kept as they are."""
    kept: list[MappedTarget] = []
    for t in sorted(targets, key=lambda m: -m.score):
        box = t.target.box
        if box is not None and any(
            k.target.box is not None and box_iou(box, k.target.box) > iou_threshold for k in kept
        ):
            continue
        kept.append(t)
    return kept


def _point(t: MappedTarget) -> Point | None:
    if t.target.points:
        return t.target.points[0]
    box = t.target.box
    return ((box[0] + box[2]) // 2, (box[1] + box[3]) // 2) if box is not None else None
