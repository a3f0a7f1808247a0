from typing import Any

import pytest

from robot_mcp_memory.documents import (
    FORMAT_SPEC,
    MAX_MARKDOWN_CHARS,
    DocumentError,
    parse_process,
    render_process,
    split_sections,
)


def problems_of(markdown: str) -> list[str]:
    with pytest.raises(DocumentError) as caught:
        parse_process(markdown)
    return caught.value.problems


def test_a_rendered_document_parses_into_its_fields(docs: Any) -> None:
    document = parse_process(docs.mailroom)

    assert document.id == "fetch-package-from-mailroom"
    assert document.title == "Fetch a package from the mailroom"
    assert document.tags == ("mailroom", "package", "fetch")
    assert document.sections["steps"].startswith("1. navigate_to(mailroom)")
    assert "DOOR_CLOSED" in document.sections["pitfalls and fixes"]
    assert document.sections["operator notes"] == "- Packages for Anna go to desk 4"
    assert not document.body.startswith("---")


def test_the_format_spec_example_is_itself_a_valid_document() -> None:
    example = FORMAT_SPEC.split("\n\nRules:")[0].split("\n\n", 1)[1]
    example = "\n".join(line.split("   #")[0].split("  #")[0] for line in example.splitlines())

    assert parse_process(example).id == "fetch-package-from-mailroom"


def test_windows_line_endings_a_bom_and_heading_variants_are_accepted() -> None:
    markdown = (
        "\ufeff---\r\nid: tidy-desk\r\ntitle: Tidy a desk\r\ntask_pattern: tidy a desk\r\n"
        "tags: desk, tidy\r\n---\r\n## steps\r\n1. wipe\r\n## Pitfalls and Fixes:\r\n"
        "## OPERATOR NOTES\r\n"
    )

    document = parse_process(markdown)

    assert document.tags == ("desk", "tidy")
    assert document.sections["pitfalls and fixes"] == ""
    assert "\r" not in document.markdown


def test_a_document_without_frontmatter_is_rejected_with_the_expected_shape() -> None:
    assert problems_of("## Steps\n1. go\n") == [
        "missing YAML frontmatter: the document must start with a line '---', then "
        "id/title/task_pattern/tags, then a closing line '---'"
    ]


def test_every_problem_of_a_bad_document_is_named_at_once() -> None:
    problems = problems_of("---\nid: Fetch Package!\ntags: 5\n---\n## Steps\n\n## Notes\nx\n")

    assert "frontmatter field 'title' is missing or empty" in problems
    assert "frontmatter field 'task_pattern' is missing or empty" in problems
    assert any("'id' ('Fetch Package!') must be a slug" in problem for problem in problems)
    assert any("'tags' must be a list of strings" in problem for problem in problems)
    assert "missing section '## Pitfalls & fixes'" in problems
    assert "missing section '## Operator notes'" in problems
    assert "section '## Steps' is empty; list at least one step" in problems


def test_invalid_yaml_names_the_frontmatter_line() -> None:
    problems = problems_of("---\nid: a\ntitle: [unclosed\ntask_pattern: x\n---\n## Steps\n1. a\n")

    assert len(problems) == 1
    assert problems[0].startswith("the frontmatter is not valid YAML at frontmatter line")


def test_frontmatter_that_is_not_a_mapping_is_rejected() -> None:
    assert problems_of("---\n- a\n- b\n---\n## Steps\n1. a\n") == [
        "the frontmatter must be a YAML mapping with keys id, title, task_pattern, tags"
    ]


def test_empty_and_oversized_documents_are_rejected(docs: Any) -> None:
    assert problems_of("   ") == ["the document is empty; send the whole markdown process document"]
    big = docs.mailroom + "x" * MAX_MARKDOWN_CHARS
    assert "the limit is" in problems_of(big)[0]


def test_non_string_fields_and_bad_tags_are_named() -> None:
    markdown = render_process("ok-id", "T", "p", ["fine"], ["s"]).replace(
        "title: T", "title: {a: 1}"
    )
    markdown = markdown.replace("- fine", "- ''\n- " + "x" * 50)

    problems = problems_of(markdown)

    assert "frontmatter field 'title' must be a string" in problems
    assert "tag '' must be a non-empty string" in problems
    assert any("is longer than 40" in problem for problem in problems)


def test_too_many_tags_and_overlong_fields_are_rejected() -> None:
    markdown = render_process("ok-id", "T" * 201, "p", [f"t{i}" for i in range(21)], ["s"])

    problems = problems_of(markdown)

    assert "frontmatter field 'title' is longer than 200 characters" in problems
    assert "frontmatter field 'tags' has 21 entries; the limit is 20" in problems


def test_a_repeated_section_is_rejected(docs: Any) -> None:
    markdown = docs.mailroom + "\n## Steps\n1. again\n"

    assert problems_of(markdown) == ["section '## Steps' appears more than once"]


def test_headings_inside_code_fences_and_deeper_headings_stay_in_their_section() -> None:
    sections = split_sections(
        "# Title\n## Steps\n1. a\n```\n## Operator notes\n```\n### Detail\nmore\n# End\nlost\n"
    )

    assert list(sections) == ["steps"]
    assert "## Operator notes" in sections["steps"]
    assert "### Detail" in sections["steps"]
    assert "lost" not in sections["steps"]


def test_numeric_ids_titles_and_tags_are_read_as_text() -> None:
    markdown = render_process("x", "T", "p", [], ["s"]).replace("id: x", "id: 42")
    markdown = markdown.replace("tags: []", "tags: [7, Mail  Room, mail room]")

    document = parse_process(markdown)

    assert document.id == "42"
    assert document.tags == ("7", "mail room")
