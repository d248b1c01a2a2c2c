"""Reading the inputs commands share: one convention for naming a design."""

from __future__ import annotations

from pathlib import Path

from ._output import UsageError

__all__ = ["design_argument", "saved_path"]


def design_argument(text: str):
    """The design a ``DESIGN`` argument names: a TOML file, or a packaged example's name.

    ``states``, ``simulate`` and ``snap`` all take ``gripper`` or ``pickplace`` for the
    examples in :mod:`dpfexplore.examples` (a file of that name in the working directory wins).

    Raises
    ------
    UsageError
        If it names neither, or the file is not a valid design (naming file and key).
    """
    from ..examples import NAMES, example_path
    from ..model.design import load_design

    path = Path(text)
    if not path.exists() and text in NAMES:
        path = example_path(text)
    if not path.exists():
        raise UsageError(f"{text}: no such design file (examples: {', '.join(NAMES)})")
    try:
        return load_design(path)
    except (OSError, ValueError) as exc:
        raise UsageError(str(exc)) from None


def saved_path(name: str, folder: Path) -> Path:
    """A saved result a command names: a path, or a bare name under ``folder``.

    ``surrogate report paper-box`` reads ``results/surrogates/paper-box``; anything with a
    folder in it, or an existing directory, is taken as given.
    """
    path = Path(name)
    if path.is_dir() or path.parent != Path("."):
        return path
    return folder / name
