"""What a newcomer finds: every method in one place, with its page and its tests; every link of the README resolves."""

import re
from pathlib import Path

import tinsmith

ROOT = Path(__file__).resolve().parents[1]


def _method_table() -> list[str]:
    lines = (ROOT / "README.md").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| `greedy`"))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        rows.append(line)
    return rows


def test_readme_method_table_links_resolve_to_one_file_each():
    rows = _method_table()
    assert len(rows) >= len(tinsmith.methods())
    targets = [t for row in rows for t in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", row) if "://" not in t]
    assert targets
    missing = [t for t in targets if not (ROOT / t).is_file()]
    assert not missing, f"README method table links to nothing: {missing}"


def test_every_registered_method_has_its_family_package_page_and_tests():
    for record in tinsmith.methods():
        parts = record.module.split(".")
        assert parts[:2] == ["tinsmith", "algorithms"] and len(parts) == 4, (
            f"{record.name}: its module {record.module} is not in a family subpackage of tinsmith.algorithms")
        assert (ROOT / "src" / Path(*parts)).with_suffix(".py").is_file()
        assert (ROOT / "docs" / "methods" / f"{record.name}.md").is_file(), f"{record.name} has no docs page"
        assert (ROOT / "tests" / f"test_{record.name}.py").is_file(), f"{record.name} has no test module"


def test_families_list_their_modules():
    families = [p for p in (ROOT / "src/tinsmith/algorithms").iterdir() if (p / "__init__.py").is_file()]
    assert len(families) >= 8
    for family in families:
        doc = (family / "__init__.py").read_text()
        for module in family.glob("*.py"):
            if module.name != "__init__.py":
                assert f":mod:`.{module.stem}`" in doc, f"{family.name}/__init__.py does not list {module.name}"


def test_every_cli_module_is_small():
    """One module per command, each a thin parse -> API call -> report."""
    sizes = {p.name: len(p.read_text().splitlines()) for p in (ROOT / "src/tinsmith/cli").glob("*.py")}
    assert {"simplify.py", "lod.py", "tile.py", "compare.py", "metrics.py", "remesh.py", "city.py"} <= set(sizes)
    big = {name: n for name, n in sizes.items() if n > 250}
    assert not big, f"CLI modules over 250 lines: {big}"


def test_help_groups_commands_by_task():
    from click.testing import CliRunner

    from tinsmith.cli.main import SECTIONS, build_cli

    cli = build_cli()
    text = CliRunner().invoke(cli, ["--help"]).output
    for title, _ in SECTIONS:
        assert f"{title}:" in text
    listed = {n for _, names in SECTIONS for n in names}
    shown = {n for n, command in cli.commands.items() if not command.hidden}  # hidden: old names (urban)
    assert shown == listed, "a command is missing from the sections of tinsmith --help"
