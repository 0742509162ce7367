"""docs/quickstart.ipynb runs top to bottom in a real Jupyter kernel (nbclient + ipykernel).

Its sweeps run with jobs=2: the worker pool starts its processes from a kernel, where
``__main__`` is no script. The kernel is this interpreter's (a kernel spec written for the
test), and it works in a temporary folder: the notebook's own files go under its TMPDIR.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "quickstart.ipynb"
KERNEL = "hoopbench-test"


def kernel_spec(folder: Path) -> Path:
    """A kernel spec named KERNEL that starts this interpreter, under folder/kernels."""
    spec = folder / "kernels" / KERNEL
    spec.mkdir(parents=True)
    argv = [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"]
    (spec / "kernel.json").write_text(
        json.dumps({"argv": argv, "display_name": KERNEL, "language": "python"})
    )
    return folder


def test_the_notebook_is_stored_without_outputs():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code and all(not c.outputs and c.execution_count is None for c in code)


@pytest.mark.slow
def test_the_quickstart_runs_in_a_kernel(tmp_path, monkeypatch):
    monkeypatch.setenv("JUPYTER_PATH", str(kernel_spec(tmp_path / "jupyter")))
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the kernel's tempfile.mkdtemp goes here
    monkeypatch.delenv("MPLBACKEND", raising=False)  # ipykernel then picks its inline one
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(
        notebook,
        kernel_name=KERNEL,
        timeout=300,  # per cell; the whole notebook takes well under a minute
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()  # a cell that raises fails here, with its traceback
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 5  # the scene, the exact run, engine vs exact, suite, map
    (work,) = tmp_path.glob("hoopbench-quickstart-*")
    assert (work / "suite" / "runs.csv").is_file() and (work / "map" / "map.toml").is_file()
    report = (work / "report" / "report.md").read_text()
    assert "## Hop map" in report
