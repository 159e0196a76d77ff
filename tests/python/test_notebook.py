"""The example notebook (examples/python/kinematics.ipynb) executed headless with nbconvert, as
a user's Jupyter would run it: every cell runs (its asserts included) and the plots come out."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "python" / "kinematics.ipynb"


def test_notebook_runs_headless(tmp_path):
    nbformat = pytest.importorskip("nbformat")
    jupyter = shutil.which("jupyter")
    if jupyter is None:
        pytest.skip("jupyter-nbconvert is not installed")
    import scaratwin

    # the kernel runs in the notebook's folder: the package this test imports, by absolute path
    package_root = str(Path(scaratwin.__file__).resolve().parents[1])
    env = dict(os.environ, PYDEVD_DISABLE_FILE_VALIDATION="1",
               PYTHONPATH=os.pathsep.join([package_root, os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([jupyter, "nbconvert", "--to", "notebook", "--execute",
                          "--ExecutePreprocessor.timeout=300", "--output-dir", str(tmp_path),
                          str(NOTEBOOK)], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr
    nb = nbformat.read(tmp_path / NOTEBOOK.name, as_version=4)
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) == 3
    text = "".join(o.get("text", "") for o in outputs)
    assert "solved:" in text and "BEYOND_REACH" in text and "gripper events" in text
