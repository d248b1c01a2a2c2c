"""Reading the inputs commands share: one convention for naming a design."""

from __future__ import annotations

from pathlib import Path

from .output import UsageError

__all__ = [
    "add_constants_option",
    "constants_argument",
    "constants_line",
    "constants_record",
    "design_argument",
    "design_of",
    "model_record",
    "print_constants_line",
    "refuse_failed_set",
    "saved_path",
    "with_constants",
]

CONSTANTS_HELP = (
    "constants set for k_b, alpha and the reach: a JSON file, a saved identification (its "
    "folder, or NAME for results/constants/NAME from `dpfexplore identify fit`), 'paper' or a "
    "packaged set's name ('shell-extended'); default: the one the input names, else the "
    "paper's closed forms"
)


def add_constants_option(parser) -> None:
    """Add ``--constants FILE`` (every command that evaluates designs takes it)."""
    parser.add_argument("--constants", metavar="FILE", default=None, help=CONSTANTS_HELP)


def constants_argument(text: str | None):
    """The constants set ``--constants FILE`` names (None when not given).

    Raises
    ------
    UsageError
        One line naming the file: unreadable, not a set, tampered with, or unphysical.
    """
    if text is None:
        return None
    from ...model.constants_set import ConstantsSetError, find_constants_set

    try:
        return find_constants_set(text)
    except ConstantsSetError as exc:
        raise UsageError(f"--constants {exc}") from None


def with_constants(current, given, what: str):
    """The set to run on: ``given`` (from ``--constants``) unless the input names another.

    ``current`` is the set the input carries (a design or job file's ``constants``, else the
    paper's). An input that names one set and an option that names another is refused: which
    one should win is a guess.

    Raises
    ------
    UsageError
        When both name a set and the sets differ (naming both).
    """
    from ...model.constants_set import DEFAULT

    if given is None or given == current:
        return current
    if current != DEFAULT:
        raise UsageError(
            f"--constants names constants set {given.label} but {what} names "
            f"{current.label}; give one"
        )
    return given


def refuse_failed_set(constants, allowed: bool) -> None:
    """Refuse a constants set whose file records that it failed validation, unless ``allowed``.

    ``dpfexplore design`` calls it: an optimiser on a set known to mispredict printed fingers
    returns designs that do not exist. The verdict is the set's ``validation`` table
    (:mod:`dpfexplore.measurements.verdict`).

    Raises
    ------
    UsageError
        Naming the set and its figures, and ``--allow-unvalidated``.
    """
    verdict = constants.validation
    if verdict is not None and not verdict["passes"] and not allowed:
        raise UsageError(
            f"{verdict['summary']}; design refuses a set that failed validation "
            "(--allow-unvalidated to design on it anyway)"
        )


def constants_record(constants) -> dict:
    """How JSON output names a constants set: ``{"name", "fingerprint"}``."""
    return {"name": constants.name, "fingerprint": constants.fingerprint}


def constants_line(constants) -> str | None:
    """The text outputs' line naming a set other than the paper's (None for the paper's)."""
    from ...model.constants_set import DEFAULT

    return None if constants == DEFAULT else f"constants set {constants.label}"


def print_constants_line(constants) -> None:
    """Print :func:`constants_line`, if there is one (the paper's set goes unmentioned)."""
    line = constants_line(constants)
    if line:
        print(line)


def model_record(design) -> dict:
    """What JSON output says of the model a design ran on: fitted range and constants set."""
    note = design.fitted_range_note
    return {
        "fitted_range": note is None,
        "fitted_range_note": note,
        "constants": constants_record(design.constants),
    }


def design_argument(text: str, constants=None):
    """The design a ``DESIGN`` argument names: a TOML file, or a packaged example's name.

    ``states``, ``simulate`` and ``snap`` all take ``gripper`` or ``pickplace`` for the
    examples in :mod:`dpfexplore.examples` (a file of that name in the working directory wins).
    ``constants`` (a set from ``--constants``) applies unless the file names another.

    Raises
    ------
    UsageError
        If it names neither, or the file is not a valid design (naming file and key), or the
        file and ``constants`` name different sets.
    """
    from ...examples import NAMES, example_path
    from ...model.design import load_design

    path = Path(text)
    if not path.exists() and text in NAMES:
        path = example_path(text)
    if not path.exists():
        raise UsageError(f"{text}: no such design file (examples: {', '.join(NAMES)})")
    try:
        design = load_design(path)
    except (OSError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    chosen = with_constants(design.constants, constants, str(path))
    return design if chosen is design.constants else design.replace(constants=chosen)


def design_of(args):
    """The design a command's ``DESIGN`` argument names, under its ``--constants`` set.

    Raises
    ------
    UsageError
        As :func:`design_argument` and :func:`constants_argument`.
    """
    return design_argument(args.design, constants_argument(args.constants))


def saved_path(name: str, folder: Path) -> Path:
    """A saved result a command names: a path, or a bare name under ``folder``.

    ``surrogate report paper-box`` reads ``results/surrogates/paper-box``; anything with a
    folder in it, or an existing directory, is taken as given.
    """
    path = Path(name)
    if path.is_dir() or path.parent != Path("."):
        return path
    return folder / name
