"""docs/notebook.ipynb runs top to bottom (nbclient, a fresh kernel) and shows the mesh."""

from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]


def test_notebook_runs_and_shows_the_mesh():
    nb = nbformat.read(ROOT / "docs" / "notebook.ipynb", as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(ROOT)}}).execute()
    shown = [out for cell in nb.cells if cell.cell_type == "code" for out in cell.get("outputs", [])]
    pages = [out["data"]["text/html"] for out in shown if "data" in out and "text/html" in out["data"]]
    assert any("TerrainMesh" in page and "data:image/png;base64," in page for page in pages)
    assert not any(out.get("output_type") == "error" for out in shown)
