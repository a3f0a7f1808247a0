"""The repository has a licence and every package says which (issue 31): LICENSE at the root,
the SPDX identifier in every pyproject, package.xml and package.json, and the README names the
optional extras that pull in another licence."""

from __future__ import annotations

import json
import re
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SPDX = "Apache-2.0"
UPSTREAM_INTERFACES = {"audio_common_msgs": "BSD"}
"""Interface packages copied byte for byte from upstream, with upstream's own licence."""
PYPROJECTS = [ROOT / "pyproject.toml", *sorted(ROOT.glob("packages/*/pyproject.toml"))]


def test_the_license_file_is_the_apache_license_2_0() -> None:
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "Apache License" in text
    assert "Version 2.0, January 2004" in text
    assert "END OF TERMS AND CONDITIONS" in text


@pytest.mark.parametrize("path", PYPROJECTS, ids=lambda p: str(p.parent.relative_to(ROOT)))
def test_every_python_package_declares_the_license(path: Path) -> None:
    project = tomllib.loads(path.read_text(encoding="utf-8"))["project"]
    license_ = project.get("license")
    text = license_.get("text") if isinstance(license_, dict) else license_
    assert text == SPDX, f"{path}: license = {license_!r}"


@pytest.mark.parametrize(
    "path",
    sorted(p for p in ROOT.glob("*/*/package.xml") if "node_modules" not in p.parts),
    ids=lambda p: str(p.parent.relative_to(ROOT)),
)
def test_every_ament_package_declares_the_license(path: Path) -> None:
    """Ours are Apache-2.0; a copy of an upstream interface package keeps upstream's licence,
    and the README's License section names it."""
    licenses = [e.text for e in ET.parse(path).getroot().iter("license")]
    upstream = UPSTREAM_INTERFACES.get(path.parent.name)
    assert licenses == [upstream or SPDX], path
    if upstream is not None:
        readme = (ROOT / "README.md").read_text(encoding="utf-8").split("## License", 1)[1]
        assert f"`interfaces/{path.parent.name}`" in readme
        assert upstream in readme


@pytest.mark.parametrize(
    "path",
    [ROOT / "frontend/package.json", *sorted(ROOT.glob("tools/*/package.json"))],
    ids=lambda p: str(p.parent.relative_to(ROOT)),
)
def test_every_npm_package_declares_the_license(path: Path) -> None:
    assert json.loads(path.read_text(encoding="utf-8"))["license"] == SPDX
    lock = json.loads(path.with_name("package-lock.json").read_text(encoding="utf-8"))
    assert lock["packages"][""]["license"] == SPDX  # the lock agrees (npm ci)


def test_the_readme_names_every_optional_extra_and_its_licence() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8").split("## License", 1)[1]
    assert "AGPL-3.0" in readme
    for path in PYPROJECTS:
        project = tomllib.loads(path.read_text(encoding="utf-8"))["project"]
        for extra in project.get("optional-dependencies", {}):
            if extra == "ros-wheels":
                assert "[ros-wheels]" in readme
                continue
            named = f"{project['name']}[{extra}]"
            assert re.search(re.escape(named), readme), f"README: no licence note for {named}"
