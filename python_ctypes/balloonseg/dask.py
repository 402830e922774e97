"""A cohort on a Dask cluster: the manifest of ``balloonseg batch`` with one Dask task per case
(``pip install 'balloonseg[dask]'``; the core package never needs Dask).

>>> from dask.distributed import Client
>>> from balloonseg import dask as bdask
>>> with Client("scheduler:8786") as client:
...     results = bdask.run_manifest("cohort.csv", "/shared/out", client)

Every worker must see the images and the output folder at the same paths (a shared file
system). Each task reads its image, segments it with the row's parameters and writes its
meshes, exactly as :func:`balloonseg.cohort.run_case` does on one machine, so the meshes equal
``balloonseg segment``'s bit for bit; a failed case comes back as a failed
:class:`~balloonseg.cohort.CaseResult`, and the other tasks go on. The client gathers the
results (with the meshes: :class:`~balloonseg.Mesh` pickles) and writes the results table.
"""

from __future__ import annotations

from pathlib import Path

from .cohort import CaseResult, check_outputs, read_manifest, run_case, write_results


def run_manifest(
    manifest, output_dir, client, *, format: str = "vtp", threads_per_case: int = 1
) -> list[CaseResult]:
    """Runs every case of ``manifest`` as a task on ``client`` (a ``dask.distributed.Client``),
    ``threads_per_case`` library threads each (the default 1 leaves the parallelism to Dask's
    workers), and writes ``results.csv`` and ``results.json`` to ``output_dir``. Returns the
    :class:`~balloonseg.cohort.CaseResult` of each case in the manifest's order. The manifest is
    checked before any task is submitted, and so is that no case's mesh would replace its image."""
    cases = read_manifest(manifest)
    check_outputs(cases, output_dir, format)
    output_dir = Path(output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    futures = client.map(
        run_case,
        cases,
        output_dir=str(output_dir),
        format=format,
        threads=threads_per_case,
        key=[f"balloonseg-case-{case.id}" for case in cases],
        pure=False,
    )
    results = client.gather(futures)
    write_results(results, output_dir)
    return results
