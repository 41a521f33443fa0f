"""Execute every ``notebooks/*.py`` (jupytext py:percent) in fast mode with nbclient.

Each notebook is converted in memory and run from a temporary working directory, so no output
is written to the repository.  The ``python3`` kernel is a kernelspec written for this test into a
temporary Jupyter data directory, pointing at ``sys.executable``: it works on a fresh machine (no
``python -m ipykernel install`` needed) and always runs the interpreter that has fsmctl installed.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.py"))
KERNEL = "python3"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def notebook_environment(tmp_path_factory):
    """A private kernelspec for ``sys.executable`` and the fast-mode environment, restored afterwards."""
    from ipykernel.kernelspec import install

    prefix = tmp_path_factory.mktemp("jupyter")
    install(kernel_name=KERNEL, prefix=str(prefix))
    spec = prefix / "share" / "jupyter" / "kernels" / KERNEL / "kernel.json"
    data = json.loads(spec.read_text())
    data["argv"][0] = sys.executable
    spec.write_text(json.dumps(data))
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(
            "JUPYTER_PATH",
            os.pathsep.join(filter(None, [str(prefix / "share" / "jupyter"), os.environ.get("JUPYTER_PATH")])),
        )
        mp.setenv("FSMCTL_FAST", "1")
        mp.setenv("MPLBACKEND", "Agg")
        yield prefix


def test_there_are_notebooks():
    names = {p.name for p in NOTEBOOKS}
    assert {"01_derivation.py", "02_proof_check.py", "04_theorem3.py", "05_robustness.py"} <= names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path, notebook_environment, tmp_path, monkeypatch):
    import jupytext
    import nbclient
    from jupyter_client.kernelspec import KernelSpecManager

    assert KernelSpecManager().get_kernel_spec(KERNEL).argv[0] == sys.executable
    source = path.read_text()
    copy = tmp_path / path.name
    copy.write_text(source)
    nb = jupytext.read(copy)
    assert nb.cells, f"{path.name} has no cells"
    assert all(not cell.get("outputs") for cell in nb.cells if cell.cell_type == "code"), (
        "outputs must not be committed"
    )
    monkeypatch.chdir(tmp_path)
    client = nbclient.NotebookClient(
        nb, kernel_name=KERNEL, timeout=600, resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    errors = [
        o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.get("output_type") == "error"
    ]
    assert not errors
    assert path.read_text() == source  # the repository copy is untouched
