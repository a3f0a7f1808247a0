from pathlib import Path

import pytest

from mcp_skill_control.catalog import Catalog, CatalogError
from mcp_skill_control.config import DEFAULT_CATALOG
from mcp_skill_control.params import ParamSpec


@pytest.fixture
def catalog() -> Catalog:
    return Catalog.load(DEFAULT_CATALOG)


def test_the_shipped_catalog_has_the_five_templates_of_the_spec(catalog: Catalog) -> None:
    assert [t.name for t in catalog.list()] == [
        "find_object",
        "segment_all",
        "free_space",
        "describe_scene",
        "watch_for",
    ]
    assert catalog.get("find_object").params == (ParamSpec("query", "string"),)
    assert catalog.get("watch_for").is_watcher
    assert not catalog.get("describe_scene").is_watcher


def test_fill_substitutes_params_and_names_the_skill_after_the_template(
    catalog: Catalog,
) -> None:
    skill = catalog.fill("find_object", {"query": "scissors"})
    assert skill["name"] == "find_object"
    assert skill["mode"] == "ground_and_segment"
    assert skill["grounding"] == "the scissors"
    assert skill["segment"] is True
    assert skill["outputs"] == [
        {"name": "found", "type": "boolean", "description": "whether the scissors is visible"}
    ]
    assert skill["description"] == "Locate and segment a specific object the user names."


def test_fill_does_not_mutate_the_template(catalog: Catalog) -> None:
    catalog.fill("find_object", {"query": "scissors"})
    assert catalog.get("find_object").skill["grounding"] == "the {query}"


def test_a_watcher_template_carries_its_watch_block_into_the_skill(catalog: Catalog) -> None:
    skill = catalog.fill("watch_for", {"condition": "the door is open"})
    assert skill["watch"] == {"output": "triggered", "equals": True}
    assert skill["outputs"][0]["description"] == "whether: the door is open"
    assert skill["once"] is False


def test_a_missing_param_is_refused(catalog: Catalog) -> None:
    with pytest.raises(CatalogError) as info:
        catalog.fill("find_object", {})
    assert info.value.code == "missing_params"
    assert "query" in info.value.detail


def test_an_unknown_template_is_refused_with_the_known_names(catalog: Catalog) -> None:
    with pytest.raises(CatalogError) as info:
        catalog.fill("fly", {})
    assert info.value.code == "unknown_template"
    assert "find_object" in info.value.detail


@pytest.mark.parametrize(
    ("params", "code"),
    [
        ({"query": "x", "colour": "red"}, "unknown_params"),
        ({"query": ""}, "invalid_params"),
        ({"query": ["a"]}, "invalid_params"),
        ({"query": True}, "invalid_params"),
        ({"query": "x" * 600}, "invalid_params"),
    ],
)
def test_bad_params_are_refused(catalog: Catalog, params: dict[str, object], code: str) -> None:
    with pytest.raises(CatalogError) as info:
        catalog.fill("find_object", params)
    assert info.value.code == code


def test_a_template_that_fills_into_an_invalid_skill_is_refused_at_load(tmp_path: Path) -> None:
    path = tmp_path / "skills.yaml"
    path.write_text(
        "templates:\n  - name: bad\n    params: []\n    skill: {mode: region}\n",
        encoding="utf-8",
    )
    with pytest.raises(CatalogError) as info:
        Catalog.load(path)
    assert info.value.code == "missing_grounding"  # the vision node's own code


@pytest.mark.parametrize(
    ("text", "code"),
    [
        ("templates: 3\n", "catalog_invalid"),
        ("templates:\n  - 3\n", "catalog_invalid"),
        ("templates:\n  - {skill: {mode: describe}}\n", "catalog_invalid"),
        ("templates:\n  - {name: a}\n", "catalog_invalid"),
        ("templates:\n  - {name: a, params: x, skill: {mode: describe}}\n", "catalog_invalid"),
        (
            "templates:\n  - {name: a, params: [{name: n, type: date}], skill: {mode: describe}}\n",
            "catalog_invalid",
        ),
        ("templates:\n  - {name: a, params: [3], skill: {mode: describe}}\n", "catalog_invalid"),
        ("templates:\n  - {name: a, watch: 1, skill: {mode: describe}}\n", "catalog_invalid"),
        ("templates: [\n", "catalog_unreadable"),
        (
            "templates:\n  - {name: a, skill: {mode: describe}}\n"
            "  - {name: a, skill: {mode: describe}}\n",
            "duplicate_template",
        ),
        (
            "templates:\n  - {name: a, params: [], skill: {mode: region, grounding: '{x}'}}\n",
            "undeclared_param",
        ),
    ],
)
def test_malformed_catalogs_are_refused_with_a_clear_code(
    tmp_path: Path, text: str, code: str
) -> None:
    path = tmp_path / "skills.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(CatalogError) as info:
        Catalog.load(path)
    assert info.value.code == code


def test_a_missing_catalog_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CatalogError) as info:
        Catalog.load(tmp_path / "nope.yaml")
    assert info.value.code == "catalog_unreadable"


TYPED = """
templates:
  - name: watch_rate
    description: "Watch {what} at {rate} Hz"
    params:
      - what
      - {name: rate, type: number}
      - {name: once, type: boolean}
      - {name: n, type: integer}
    skill:
      mode: describe
      rate_hz: "{rate}"
      once: "{once}"
      outputs:
        - {name: seen, type: boolean, description: "whether {n} {what} are visible ({once})"}
"""


@pytest.fixture
def typed(tmp_path: Path) -> Catalog:
    path = tmp_path / "skills.yaml"
    path.write_text(TYPED, encoding="utf-8")
    return Catalog.load(path)


def test_typed_params_fill_numbers_and_booleans_as_the_template_declares(typed: Catalog) -> None:
    skill = typed.fill("watch_rate", {"what": "cups", "rate": 2, "once": True, "n": 3})

    assert skill["rate_hz"] == 2.0
    assert skill["once"] is True
    assert skill["outputs"][0]["description"] == "whether 3 cups are visible (true)"
    assert skill["description"] == "Watch cups at 2 Hz"


def test_typed_params_read_numbers_and_booleans_sent_as_text(typed: Catalog) -> None:
    skill = typed.fill("watch_rate", {"what": "cups", "rate": "0.5", "once": "false", "n": "4"})

    assert (skill["rate_hz"], skill["once"]) == (0.5, False)


@pytest.mark.parametrize(
    "params",
    [
        {"what": "cups", "rate": "fast", "once": True, "n": 1},
        {"what": "cups", "rate": True, "once": True, "n": 1},
        {"what": "cups", "rate": 1, "once": "yes", "n": 1},
        {"what": "cups", "rate": 1, "once": 1, "n": 1},
        {"what": "cups", "rate": 1, "once": True, "n": 1.5},
        {"what": True, "rate": 1, "once": True, "n": 1},
    ],
)
def test_a_param_of_the_wrong_type_is_refused(typed: Catalog, params: dict[str, object]) -> None:
    with pytest.raises(CatalogError) as info:
        typed.fill("watch_rate", params)
    assert info.value.code == "invalid_params"


def test_a_string_param_accepts_a_number(catalog: Catalog) -> None:
    skill = catalog.fill("free_space", {"what": 3})
    assert skill["grounding"] == "free flat space large enough for the 3"


def test_templates_publish_their_param_types(typed: Catalog) -> None:
    summary = typed.get("watch_rate").summary()
    assert summary["params"] == ["what", "rate", "once", "n"]
    assert summary["param_types"] == {
        "what": "string",
        "rate": "number",
        "once": "boolean",
        "n": "integer",
    }
