"""The method pages: one per registered method, naming every option, with a picture that exists."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import tinsmith

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.mark.parametrize("method", [m.name for m in tinsmith.methods()])
def test_every_method_has_a_page_with_its_options_and_a_picture(method):
    page = DOCS / "methods" / f"{method}.md"
    assert page.exists(), f"docs/methods/{method}.md is missing"
    text = page.read_text()
    record = tinsmith.get_method(method)
    for name in [o.name for o in record.options] + list(record.stop_rules):
        assert f"`{name}`" in text, f"{page.name} does not document {name}"
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert pictures and all((page.parent / p).exists() for p in pictures)
    assert "Paper" in text
    assert f"[{method}.md]" in (DOCS / "methods" / "README.md").read_text()
