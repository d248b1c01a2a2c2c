"""The tutorial notebook, executed once and kept with its outputs for the docs to show.

``docs/tutorial.ipynb`` is stored without outputs. :func:`executed_notebook` runs it from top to
bottom (nbclient, in ``docs/``) and keeps the executed copy in
``docs/_generated/tutorial.executed.ipynb`` (git-ignored), labelled with the SHA-256 of the
source notebook and the seconds the run took. Whoever asks first runs it: ``tests/test_tutorial.py``
or the Sphinx build (``generated_pages``); the other reads the copy, so the notebook is executed
once per change. A lock file serialises the two (the test suite runs them in two processes).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import time
import warnings
from pathlib import Path
from typing import Any

#: Seconds a cell may run before the execution fails.
CELL_TIMEOUT_S = 120


def _digest(notebook: Path) -> str:
    return hashlib.sha256(notebook.read_bytes()).hexdigest()


@contextlib.contextmanager
def _locked(path: Path):
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def executed_notebook(notebook: Path, out_dir: Path) -> tuple[dict[str, Any], float]:
    """The notebook with its outputs, and the seconds its execution took.

    Executes it when ``out_dir/<stem>.executed.ipynb`` is missing or was made from another
    version of ``notebook`` (its recorded SHA-256); else reads that copy.
    """
    copy = out_dir / f"{notebook.stem}.executed.ipynb"
    digest = _digest(notebook)
    with _locked(out_dir / f".{notebook.stem}.lock"):
        if copy.is_file():
            kept = json.loads(copy.read_text(encoding="utf-8"))
            facts = kept.get("metadata", {}).get("dpfexplore", {})
            if facts.get("source_sha256") == digest:
                return kept, float(facts["seconds"])
        with warnings.catch_warnings():
            # jupyter_core/jupyter_client deprecations on import and kernel start are not ours
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", RuntimeWarning)
            import nbformat
            from nbclient import NotebookClient

            nb = nbformat.read(notebook, as_version=4)
            client = NotebookClient(
                nb,
                kernel_name="python3",
                timeout=CELL_TIMEOUT_S,
                resources={"metadata": {"path": str(notebook.parent)}},
            )
            started = time.perf_counter()
            # the kernel draws inline (its default backend), whatever backend this process uses:
            # the Sphinx build sets MPLBACKEND=Agg, which would leave the figures out
            client.execute(env={k: v for k, v in os.environ.items() if k != "MPLBACKEND"})
            seconds = time.perf_counter() - started
        nb.metadata["dpfexplore"] = {"source_sha256": digest, "seconds": seconds}
        text = nbformat.writes(nb)
        partial = copy.with_suffix(".partial")
        partial.write_text(text, encoding="utf-8")
        partial.replace(copy)
        return json.loads(text), seconds
