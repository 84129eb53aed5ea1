"""The documentation site (Sphinx: the pages of docs/ and the API from the docstrings) builds without a warning."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_docs_site_builds_without_warnings(tmp_path):
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-E", "-q", "-b", "html", str(ROOT / "docs"),
                           str(tmp_path / "site")], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    api = (tmp_path / "site" / "api.html").read_text()
    for name in ("simplify", "Heightfield", "TerrainMesh", "to_xarray", "greedy", "remesh"):
        assert name in api
    assert (tmp_path / "site" / "methods" / "quality.html").is_file()
