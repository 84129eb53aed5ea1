"""The layers of the package as code: the import contracts of pyproject.toml hold, and no import makes a cycle.

``lint-imports`` (import-linter) checks the contracts of ``[tool.importlinter]``: a module
imports only its own layer and the layers under it, the layers are the ones docs/design.md
draws, and every module has its place in them.  A cycle is caught even inside one layer:
two modules that import each other, through any chain, can neither be read nor imported
one without the other.
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_import_contracts_hold(capsys, monkeypatch):
    cli = pytest.importorskip("importlinter.cli", reason="import-linter is not installed: pip install -e '.[test]'")
    monkeypatch.chdir(ROOT)
    code = cli.lint_imports(config_filenames=(str(ROOT / "pyproject.toml"),), no_cache=True, no_logo=True)
    assert code == 0, capsys.readouterr().out


def _cycles(graph) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, without recursion)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    for start in sorted(graph.modules):
        if start in index:
            continue
        work = [(start, iter(sorted(graph.find_modules_directly_imported_by(start))))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            module, targets = work[-1]
            for target in targets:
                if target not in index:
                    index[target] = low[target] = len(index)
                    stack.append(target)
                    on_stack.add(target)
                    work.append((target, iter(sorted(graph.find_modules_directly_imported_by(target)))))
                    break
                if target in on_stack:
                    low[module] = min(low[module], index[target])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[module])
                if low[module] == index[module]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == module:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def test_no_module_imports_itself_through_others():
    grimp = pytest.importorskip("grimp", reason="grimp (import-linter's graph) is not installed: pip install -e '.[test]'")
    graph = grimp.build_graph("tinsmith", cache_dir=None)
    cycles = list(_cycles(graph))
    shown = []
    for component in cycles:
        a, b = component[0], component[1]
        chain = graph.find_shortest_chain(importer=a, imported=b) + graph.find_shortest_chain(importer=b, imported=a)[1:]
        shown.append(" -> ".join(chain))
    assert not cycles, "import cycles:\n" + "\n".join(shown)


def test_the_cycle_finder_finds_a_cycle():
    grimp = pytest.importorskip("grimp", reason="grimp (import-linter's graph) is not installed: pip install -e '.[test]'")
    graph = grimp.ImportGraph()
    for name in ("p", "p.a", "p.b", "p.c", "p.d"):
        graph.add_module(name)
    for importer, imported in (("p.a", "p.b"), ("p.b", "p.c"), ("p.c", "p.a"), ("p.d", "p.a")):
        graph.add_import(importer=importer, imported=imported)
    assert _cycles(graph) == [["p.a", "p.b", "p.c"]]
