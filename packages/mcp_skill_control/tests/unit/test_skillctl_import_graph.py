"""No import cycles inside the package (issue 13 "Structure": composition.py <-> server.py)."""

from __future__ import annotations

import grimp

PACKAGE = "mcp_skill_control"


def test_no_module_of_the_package_imports_itself_through_others() -> None:
    graph = grimp.build_graph(PACKAGE)
    cycles = sorted(
        (module, imported)
        for module in graph.modules
        for imported in graph.find_modules_directly_imported_by(module)
        if imported.startswith(PACKAGE) and graph.chain_exists(imported=module, importer=imported)
    )

    assert cycles == []


def test_the_server_module_does_not_import_the_composition_root() -> None:
    graph = grimp.build_graph(PACKAGE)

    assert f"{PACKAGE}.composition" not in graph.find_upstream_modules(f"{PACKAGE}.server")
