"""examples/notebooks/quickstart.ipynb executed headless, as a user's Jupyter would."""

import os

import matplotlib.image
import nbformat
from nbclient import NotebookClient

from conftest import WORKSPACE


def test_the_quickstart_notebook_runs_and_its_figure_is_not_blank(tmp_path):
    nb = nbformat.read(WORKSPACE / "examples" / "notebooks" / "quickstart.ipynb", as_version=4)
    os.environ["SWARMRT_NOTEBOOK_OUT"] = str(tmp_path)
    NotebookClient(nb, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    errors = [o for c in nb.cells for o in c.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors, errors
    pixels = matplotlib.image.imread(tmp_path / "flocking_crossing.png")
    assert pixels.std() > 0.01, "the figure is not blank"
    printed = "".join(o.get("text", "") for c in nb.cells for o in c.get("outputs", []))
    assert "robot-steps/s" in printed and "9 robot processes" in printed
