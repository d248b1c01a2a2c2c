"""What a sweep directory holds right now: its committed chunks and their checksum.

A sweep directory's ``_manifest.json`` is its commit record (:mod:`dpfexplore.sweep.storage.store`):
a chunk exists for readers once the manifest lists it. :func:`dataset_info` reads it into a
:class:`DatasetInfo`, whose :attr:`~DatasetInfo.checksum` identifies the data: SHA-256 over the job
fingerprint, the model version and the committed chunk records (each with its file's SHA-256). Any
committed change to the data - a sweep that went on, a chunk recomputed by ``--resume`` - changes
it; a rewrite of the manifest that changes no data (a ``--resume`` with nothing to do rewrites the
timestamps) does not. Anything derived from a dataset (the lookup index) records this checksum and
is refused when it no longer matches.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa

from ...model.constants_set import DEFAULT, ConstantsSet, ConstantsSetError, find_constants_set
from .store import (
    ChunkRecord,
    Manifest,
    StoreError,
    chunk_bytes,
    read_manifest,
    unverified_chunk,
)

__all__ = ["DatasetInfo", "dataset_checksum", "dataset_info"]


def dataset_checksum(manifest: Manifest) -> str:
    """SHA-256 of what a dataset holds: job fingerprint, model version, committed chunks.

    Each chunk record carries its file's SHA-256, row count and plan range, so two manifests
    have equal checksums exactly when they commit the same files with the same bytes.
    """
    content = {
        "fingerprint": manifest.fingerprint,
        "model_version": manifest.model_version,
        "chunks": sorted(
            (r.path, r.sha256, r.rows, r.start, r.stop) for r in manifest.chunks.values()
        ),
    }
    text = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class DatasetInfo:
    """What a sweep directory holds right now (from its manifest).

    Attributes
    ----------
    root : Path
    checksum : str
        :func:`dataset_checksum`.
    complete : bool
        Every chunk of the plan is committed. False while a sweep is writing it (or after one
        stopped early): readers then see the committed chunks only.
    designs_committed, designs_planned : int
    rows_committed : int
        Design-state rows in the committed chunks.
    chunks : tuple of str
        Committed chunk files (relative paths), in (N, chunk) order.
    job : dict
        The job that wrote the dataset (:meth:`~dpfexplore.sweep.space.JobSpec.to_dict`).
    model_version : str
        Model version that wrote the dataset.
    records : tuple of ChunkRecord
        The committed chunks' manifest records, in the order of :attr:`chunks`.
    constants : dict
        ``{"name", "fingerprint"}`` of the constants set the rows were computed under (the
        paper's for a dataset whose manifest records none).
    """

    root: Path
    checksum: str
    complete: bool
    designs_committed: int
    designs_planned: int
    rows_committed: int
    chunks: tuple[str, ...]
    job: Mapping = field(default_factory=dict, compare=False, repr=False)
    model_version: str = ""
    records: tuple[ChunkRecord, ...] = field(default=(), compare=False, repr=False)
    constants: Mapping = field(default_factory=dict, compare=False, repr=False)

    def constants_set(self, given: ConstantsSet | None = None) -> ConstantsSet:
        """The constants set the dataset's rows were computed under, checked.

        ``given`` (a user's ``--constants``) must be that set; without it, the paper's set or
        the file the job named (``job.constants``), which must still hold the same set.

        Raises
        ------
        StoreError
            One line naming both sets when ``given`` is another set, or when the job's file is
            gone or now holds another set.
        """
        recorded = self.constants or {"name": DEFAULT.name, "fingerprint": DEFAULT.fingerprint}
        wanted = f"{recorded['name']!r} ({str(recorded['fingerprint'])[:12]})"
        if given is not None:
            if given.fingerprint != recorded["fingerprint"]:
                raise StoreError(
                    f"{self.root}: its rows were computed under constants set {wanted}, not "
                    f"{given.label}: a dataset answers for its own set only"
                )
            return given
        if recorded["fingerprint"] == DEFAULT.fingerprint:
            return DEFAULT
        source = self.job.get("job", {}).get("constants")
        try:
            found = find_constants_set(source) if source else None
        except ConstantsSetError as exc:
            raise StoreError(
                f"{self.root}: its rows were computed under constants set {wanted}, whose "
                f"file cannot be used ({exc}); pass --constants FILE with that set"
            ) from None
        if found is None or found.fingerprint != recorded["fingerprint"]:
            raise StoreError(
                f"{self.root}: its rows were computed under constants set {wanted}; "
                f"{source or 'its file'} now holds "
                f"{found.label if found else 'nothing'}: pass --constants FILE with that set"
            )
        return found

    def open_chunk(self, path: str, *, verify: bool = True) -> pa.BufferReader | Path:
        """A committed chunk file for :func:`pyarrow.parquet.read_table`.

        With ``verify``, the file's bytes checked against the manifest's size and SHA-256
        (:func:`~dpfexplore.sweep.storage.store.chunk_bytes`: a chunk changed after it was committed
        is a StoreError naming it), so that what is decoded is what was checked.
        """
        if not verify:
            return unverified_chunk(self.root / path)
        record = next(r for r in self.records if r.path == path)
        return pa.BufferReader(chunk_bytes(self.root, record))

    @property
    def note(self) -> str | None:
        """One line for the user when the dataset is incomplete (None when complete)."""
        if self.complete:
            return None
        return (
            f"dataset incomplete: {self.designs_committed} of {self.designs_planned} designs "
            "committed (a sweep may still be writing it); using the committed chunks only"
        )


def dataset_info(root: str | Path) -> DatasetInfo:
    """Read a sweep directory's manifest.

    Raises
    ------
    StoreError
        If ``root`` does not exist or is not a sweep directory.
    """
    root = Path(root)
    if not root.exists():
        raise StoreError(f"{root}: no such dataset directory")
    if not root.is_dir():
        raise StoreError(f"{root}: not a directory (a sweep dataset is a directory)")
    manifest = read_manifest(root)
    records = sorted(manifest.chunks.values(), key=lambda r: (r.n_units, r.index))
    return DatasetInfo(
        root=root,
        checksum=dataset_checksum(manifest),
        complete=bool(manifest.complete),
        designs_committed=manifest.n_designs_committed,
        designs_planned=sum(manifest.plan.values()),
        rows_committed=manifest.n_rows,
        chunks=tuple(r.path for r in records),
        job=manifest.job,
        model_version=manifest.model_version,
        records=tuple(records),
        constants=dict(manifest.result_defining.get("constants") or {}),
    )
