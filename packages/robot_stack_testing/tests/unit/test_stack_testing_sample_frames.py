from __future__ import annotations

import json
from pathlib import Path

from robot_stack_testing.sample_frames import frames_showing


def scene(folder: Path, name: str, *annotations: dict[str, str]) -> None:
    (folder / f"{name}.png").write_bytes(b"png")
    (folder / f"{name}.json").write_text(json.dumps({"annotations": list(annotations)}))


def test_only_frames_that_plainly_show_the_label_are_copied_up_to_the_limit(
    tmp_path: Path,
) -> None:
    scenes, camera = tmp_path / "scenes", tmp_path / "camera"
    scenes.mkdir()
    scene(scenes, "a", {"label": "scissors", "difficulty": "easy"})
    scene(scenes, "b", {"label": "scissors", "difficulty": "hard"})
    scene(scenes, "c", {"label": "red mug", "difficulty": "easy"})
    scene(scenes, "d", {"label": "scissors", "difficulty": "easy"})

    assert [p.name for p in frames_showing(scenes, camera, "scissors")] == ["a.png", "d.png"]
    assert sorted(p.name for p in camera.iterdir()) == ["a.json", "a.png", "d.json", "d.png"]
    still = frames_showing(scenes, tmp_path / "still", "scissors", difficulty=None, limit=1)
    assert [p.name for p in still] == ["a.png"]
