"""The package's layers, read from its source: lower layers never import higher ones, no cycles.

Every ``import`` of a spherekin module is collected with ``ast`` (module level and inside
functions). No module imports ``verification/``, ``references/``, ``benchmarks/`` or the experiments, no private name crosses a module boundary (neither
imported nor reached as ``module._name``), and the module-level import graph has no cycle. Layers, lowest first (docs/layout.md):

output files (atomic), run control (budget) -> where work runs (cluster: Dask) -> core (spherekin/core/) -> closure equations -> mechanism model (spherekin/mechanism/) -> hand-over
types (results) -> search (spherekin/search/) -> systems (spherekin/systems/) -> trust (spherekin/trust/) -> pipeline (problem) ->
singular sets (spherekin/singularities/) -> families of inputs (spherekin/batch/) -> interfaces (cli, plot).

Rules of issue 29 beyond the order, each its own test: the search never imports the mechanism
package (it works on equations handed over as data), the trust layer never imports the search
(what both need lives below them: closure, core), and no cycle runs through imports inside
functions either (the formulations <-> parameterizations cycle is gone).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "spherekin"

LAYERS = [
    ("output files, run control", {"atomic", "budget"}),
    ("where work runs", {"cluster"}),
    ("core", {"core"}),
    ("closure equations", {"closure", "paper_gosselin"}),
    ("mechanism model", {"mechanism"}),
    ("hand-over types", {"results"}),
    ("search", {"search"}),
    ("systems", {"systems"}),
    ("trust", {"trust"}),
    ("pipeline", {"problem"}),
    ("singular sets", {"singularities"}),
    ("families of inputs", {"batch"}),
    ("interfaces", {"cli", "plot", "__main__"}),
]
LEVEL = {name: k for k, (_, names) in enumerate(LAYERS) for name in names}


def unit_of(module: str) -> str:
    """The layer unit of a dotted module name inside the package: its subpackage ('core' for
    spherekin.core.bernstein, 'mechanism' for spherekin.mechanism.model) or top-level module."""
    return module.split(".")[1] if module.count(".") else module


def modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def import_target(package: str, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` statement in ``package`` reads from."""
    if not node.level:
        return node.module or ""
    base = package.split(".")
    base = base[:len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def imports(module: str, path: Path):
    """(target module, imported names, at module level?) for every import of a spherekin module."""
    tree = ast.parse(path.read_text())
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    top_level = {id(node) for node in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            target = import_target(package, node)
            names = [a.name for a in node.names]
            if not node.module and node.level:        # from . import x: the modules x
                for n in names:
                    yield f"{target}.{n}", [], id(node) in top_level
                continue
            yield target, names, id(node) in top_level
        elif isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, [], id(node) in top_level


ALL = modules()


def test_every_module_has_a_layer():
    units = {unit_of(m) for m in ALL if m != "spherekin"}
    assert units <= set(LEVEL), f"modules without a layer in this test: {sorted(units - set(LEVEL))}"


#: The folders beside the package that check or measure it: the package never imports them.
OUTSIDE = ("verification", "references", "benchmarks", "experiments", "paper_figures")


@pytest.mark.parametrize("module", sorted(ALL))
def test_the_package_never_imports_the_verification_references_or_benchmarks(module):
    assert not any(t.split(".")[0] in OUTSIDE for t, _, _ in imports(module, ALL[module]))


@pytest.mark.parametrize("module", sorted(ALL))
def test_no_private_name_is_imported_from_another_module(module):
    for target, names, _ in imports(module, ALL[module]):
        if target.startswith("spherekin") and target != module:
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            assert not private, f"{module} imports private {private} from {target}"


def module_aliases(module: str, path: Path) -> dict[str, str]:
    """Local name -> spherekin module, for the modules bound by name (``from .core import bernstein``,
    ``import spherekin.core.intervals as iv``)."""
    tree = ast.parse(path.read_text())
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    out = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            target = import_target(package, node)
            for a in node.names:
                if f"{target}.{a.name}" in ALL:
                    out[a.asname or a.name] = f"{target}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name in ALL and a.asname:
                    out[a.asname] = a.name
    return out


@pytest.mark.parametrize("module", sorted(ALL))
def test_no_private_name_of_another_module_is_used_through_its_module(module):
    """``bernstein._x(...)`` is the same breach as ``from .bernstein import _x``."""
    aliases = module_aliases(module, ALL[module])
    for node in ast.walk(ast.parse(ALL[module].read_text())):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                and node.attr.startswith("_") and not node.attr.startswith("__")
                and aliases[node.value.id] != module):
            pytest.fail(f"{module} uses private {node.attr} of {aliases[node.value.id]}")


@pytest.mark.parametrize("module", sorted(m for m in ALL if m != "spherekin"))
def test_lower_layers_never_import_higher_ones(module):
    here = LEVEL[unit_of(module)]
    for target, names, _ in imports(module, ALL[module]):
        if target == "spherekin.__version__":
            continue                                     # the version string, from the package root
        if not target.startswith("spherekin."):
            continue
        there = LEVEL.get(unit_of(target))
        assert there is not None and there <= here, (
            f"{module} ({LAYERS[here][0]}) imports {target} ({LAYERS[there][0] if there is not None else '?'})")


def in_package(module: str, package: str) -> bool:
    """``module`` is ``package`` or one of its submodules (dotted names)."""
    return module == package or module.startswith(package + ".")


def test_the_import_reader_sees_imports_inside_functions(tmp_path):
    """Every rule below reads :func:`imports`: it must report an import in a function body as well."""
    path = tmp_path / "probe.py"
    path.write_text("def f():\n    from ..mechanism import model\n    import spherekin.search.boxloop\n")
    found = {(t, top) for t, _, top in imports("spherekin.trust.probe", path)}
    assert found == {("spherekin.mechanism", False), ("spherekin.search.boxloop", False)}


def forbidden_imports(package: str, forbidden: str) -> list[str]:
    """"module imports target" for every import (module level or in a function) of a module of
    ``package`` from ``forbidden`` (a package, dotted)."""
    return [f"{m} imports {t}" for m in ALL if in_package(m, package)
            for t, _, _ in imports(m, ALL[m]) if in_package(t, forbidden)]


def test_the_search_never_imports_the_mechanism_package():
    bad = forbidden_imports("spherekin.search", "spherekin.mechanism")
    assert not bad, "the search works on equations handed over as data, not on mechanisms: " + "; ".join(bad)


def test_the_trust_layer_never_imports_the_search():
    bad = forbidden_imports("spherekin.trust", "spherekin.search")
    assert not bad, ("what the trust layer shares with the search belongs below both (closure, core) or in "
                     "the systems: " + "; ".join(bad))


def find_cycle(graph: dict[str, set]) -> list[str] | None:
    """One cycle of ``graph`` (module -> imported modules) as a path m0 -> ... -> m0, or None."""
    state: dict[str, int] = {}

    def visit(m, stack):
        state[m] = 1
        for t in sorted(graph[m]):
            if state.get(t) == 1:
                return stack + [m, t]
            if t not in state:
                found = visit(t, stack + [m])
                if found:
                    return found
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m, [])
            if found:
                return found[found.index(found[-1]):]
    return None


def test_no_import_cycle_even_through_imports_inside_functions():
    graph = {m: {t for t, _, _ in imports(m, ALL[m]) if t in ALL and t != m and not in_package(m, t)} for m in ALL}
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle (counting imports inside functions): " + " -> ".join(cycle)


def test_the_module_level_import_graph_has_no_cycle():
    graph = {m: {t for t, _, top in imports(m, ALL[m]) if top and t in ALL and t != m} for m in ALL}
    state: dict[str, int] = {}

    def visit(m, stack):
        state[m] = 1
        for t in graph[m]:
            if state.get(t) == 1:
                pytest.fail("import cycle: " + " -> ".join(stack + [m, t]))
            if t not in state:
                visit(t, stack + [m])
        state[m] = 2

    for m in graph:
        if m not in state:
            visit(m, [])


def test_docs_layout_names_every_module_and_no_file_outside_the_tree():
    """docs/layout.md is the layout as built: every module of the package is named there (its file name),
    and it points at nothing outside the repository (a design note elsewhere is not a reader's)."""
    text = (PACKAGE.parent / "docs" / "layout.md").read_text()
    missing = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                     if p.name != "__init__.py" and p.name not in text)
    assert not missing, f"docs/layout.md does not name: {missing}"
    assert "shared/" not in text and "../" not in text
