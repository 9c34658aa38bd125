"""Execute the notebooks from their jupytext sources and write the paired .ipynb files
with their outputs.  ``make notebooks`` runs this, then each source under mpirun.

    .venv/bin/python scripts/run_notebooks.py [notebooks/01_growth_basics.py ...]
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import jupytext
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parent.parent
os.environ.setdefault("PYDEVD_DISABLE_FILE_VALIDATION", "1")  # the kernel's debugger note


def main(paths: list[str]) -> int:
    sources = [Path(p) for p in paths] or sorted((ROOT / "notebooks").glob("[0-9]*.py"))
    for source in sources:
        tic = time.perf_counter()
        notebook = jupytext.read(source)
        client = NotebookClient(notebook, timeout=900, kernel_name="python3",
                                resources={"metadata": {"path": str(ROOT)}})
        client.execute()  # raises CellExecutionError, with the cell and its traceback
        jupytext.write(notebook, source.with_suffix(".ipynb"))
        print(f"{source.name}: ran in {time.perf_counter() - tic:.0f} s, "
              f"wrote {source.with_suffix('.ipynb').name}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
