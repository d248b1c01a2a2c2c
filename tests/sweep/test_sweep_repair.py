"""``sweep --repair``: a real sweep loses its manifest and has chunks damaged; the repair
commits exactly the intact chunks, ``--resume`` recomputes the rest, and the dataset equals an
undamaged run."""

from __future__ import annotations

import shutil

import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
from sweep_helpers import job_dict, toml_text

from dpfexplore.cli import main
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.job_file import load_job
from dpfexplore.sweep.storage import store

KEY = ["design_id", "requested"]


def test_repair_commits_the_intact_chunks_and_resume_recomputes_the_rest(tmp_path, capsys):
    job = tmp_path / "repair.toml"
    job.write_text(toml_text(job_dict(**{"job.name": "repair", "compute.states": "sequential"})))
    reference = tmp_path / "reference"
    run_sweep(load_job(job), reference, chunk_size=10)  # a real sweep: 2 x 6 chunks
    expected = store.read_results(reference).sort_values(KEY).reset_index(drop=True)

    out = tmp_path / "out"
    shutil.copytree(reference, out)
    (out / store.MANIFEST).unlink()
    # Damage 1: a value changed inside a valid Parquet file that keeps its identity.
    changed = out / "N02/part-000003.parquet"
    table = pq.read_table(changed)
    tip_x = pc.multiply(table.column("tip_x"), pa.scalar(1.001))
    table = table.set_column(table.column_names.index("tip_x"), "tip_x", tip_x)
    pq.write_table(table, changed, compression="zstd")
    # Damage 2: a chunk cut short.
    cut = out / "N03/part-000001.parquet"
    cut.write_bytes(cut.read_bytes()[: cut.stat().st_size // 2])

    # Without a manifest the directory is refused, with the way out.
    assert main(["sweep", str(job), "--out", str(out), "--resume"]) == 2
    assert "rebuild it with --repair" in capsys.readouterr().err

    assert main(["sweep", str(job), "--out", str(out), "--repair"]) == 0
    said = capsys.readouterr().out
    assert "10 of 12 chunks verified against the job and committed (100 of 120 designs)" in said
    assert "left out N02/part-000003.parquet: its contents differ from the SHA-256" in said
    assert "left out N03/part-000001.parquet: unreadable" in said
    assert f"2 chunks to compute: dpfexplore sweep {job} --out {out} --resume" in said
    manifest = store.read_manifest(out)
    assert len(manifest.chunks) == 10 and not manifest.complete
    assert "N02/part-000003.parquet" not in manifest.chunks
    assert manifest.chunk_sizes == {2: 10, 3: 10}
    # What the repaired manifest commits reads back verified and equals the reference rows.
    partial = store.read_results(out).sort_values(KEY).reset_index(drop=True)
    lost = ((expected.n_units == 2) & expected["sample"].between(30, 39)) | (
        (expected.n_units == 3) & expected["sample"].between(10, 19)
    )
    kept = expected[~lost].reset_index(drop=True)
    pd.testing.assert_frame_equal(partial, kept)

    assert main(["sweep", str(job), "--out", str(out), "--resume"]) == 0
    assert "10 of 12 chunks reused" in capsys.readouterr().out
    frame = store.read_results(out).sort_values(KEY).reset_index(drop=True)
    pd.testing.assert_frame_equal(frame, expected)
    assert store.read_manifest(out).complete
