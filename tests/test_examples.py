"""Every public function and class has a numpydoc ``Examples`` section, and its examples run.

The public API is what ``import tinsmith`` gives (``tinsmith.__all__``), the
functions of ``tinsmith.shapes`` and the names of ``tinsmith.tiles``.  Each
example imports what it uses, so it runs as a reader would paste it.  A new
public function or class fails here until it has an ``Examples`` section
(or an entry in :data:`EXEMPT` that gives the reason).
"""

from __future__ import annotations

import doctest
import inspect
import re

import pytest

import tinsmith
from tinsmith import shapes, tiles

#: public name -> why it has no Examples section (keep this short)
EXEMPT: dict[str, str] = {"tinsmith.urban": "a deprecated alias of tinsmith.blocks and urban_model, kept for one release"}

FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
_HEADING = re.compile(r"^\s*Examples\s*\n\s*-{8,}\s*$", re.MULTILINE)


def _public() -> dict[str, object]:
    """Qualified name -> object of every public function and class."""
    found = {f"tinsmith.{name}": getattr(tinsmith, name) for name in tinsmith.__all__}
    found |= {f"tinsmith.tiles.{name}": getattr(tiles, name) for name in tiles.__all__}
    found |= {f"tinsmith.shapes.{name}": value for name, value in vars(shapes).items()
              if not name.startswith("_") and getattr(value, "__module__", None) == shapes.__name__}
    return {name: value for name, value in found.items() if inspect.isfunction(value) or inspect.isclass(value)}


PUBLIC = _public()


def test_the_public_api_is_collected():
    for name in ("tinsmith.simplify", "tinsmith.Heightfield", "tinsmith.greedy", "tinsmith.shapes.torus",
                 "tinsmith.tiles.tile_raster", "tinsmith.InvalidInputError"):
        assert name in PUBLIC
    assert not set(EXEMPT) - set(PUBLIC), "an exempt name that is not public any more"


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_examples_run(name):
    obj = PUBLIC[name]
    if name in EXEMPT:
        pytest.skip(EXEMPT[name])
    assert _HEADING.search(inspect.getdoc(obj) or ""), f"{name}: its docstring has no Examples section"
    tests = doctest.DocTestFinder().find(obj, name, globs={})
    assert sum(len(t.examples) for t in tests) > 0, f"{name}: its Examples section holds no >>> example"
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    report: list[str] = []
    for test in tests:
        runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
