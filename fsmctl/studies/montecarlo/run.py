"""Running a Monte Carlo campaign: its chunks declared as tasks of the campaign runner (:mod:`fsmctl.studies.campaign`)."""

from __future__ import annotations

import functools
import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fsmctl.model.scenario import Scenario
from fsmctl.parallel import CampaignInterrupted, check_workers, resolve_workers
from fsmctl.policy import DASK_TIMEOUT_S
from fsmctl.studies.campaign import Runner, Task, check_memory
from fsmctl.studies.montecarlo.runs import FLAGS, PER_AGENT, SCALARS, RunFunction, nan_record, run_chunk
from fsmctl.studies.montecarlo.settings import (
    STATUS_DIED,
    CampaignSettings,
    campaign_base,
    check_campaign,
    describe_campaign,
)
from fsmctl.studies.montecarlo.store import (
    CampaignResult,
    OutputFolder,
    campaign_record,
    chunk_dataset,
    chunk_path,
    chunk_runs,
    existing_chunk,
    finish_campaign,
    n_chunks,
    write_dataset,
)
from fsmctl.studies.wording import RESUME_HINT

RUN_RECORD_BYTES = 8 * (len(SCALARS) + len(FLAGS) + 1) + 2 * 64
"""Bytes of one run in the merged dataset besides its per-agent values: the scalars, the flags and the noise
seed (float64 or smaller) and the status and message strings (NumPy object arrays: a pointer and a short
string each, counted as 64 bytes)"""

CAMPAIGN_MEMORY_FACTOR = 4.0
"""Peak memory of the merged campaign as a multiple of its dataset: the chunk files read back, their
concatenation, the compressed NetCDF encoded in memory and the summary's copies"""


def check_campaign_memory(settings: CampaignSettings, base: Scenario, *, available: int | None = None) -> int:
    """Refuse (:class:`~fsmctl.errors.ResourceLimitError`) a campaign whose merged results would not fit in memory.

    :func:`finish_campaign` holds every run's record at once (``montecarlo.nc`` and the summary): per run
    :data:`RUN_RECORD_BYTES` plus 8 bytes per agent and per-agent statistic, times
    :data:`CAMPAIGN_MEMORY_FACTOR`.  It is compared with ``available`` (default:
    :func:`fsmctl.simulation.simulator.available_memory`; None: no check) before anything of the campaign is
    drawn, flown or written, as ``fsmctl simulate`` checks a run's results (:func:`~fsmctl.simulation.simulator.
    check_output_memory`).

    Parameters
    ----------
    settings : CampaignSettings
        The campaign (its ``runs``).
    base : Scenario
        The base scenario (its number of agents).
    available : int, optional
        Bytes available; default: what the machine has now.

    Returns
    -------
    int
        The estimate in bytes.

    Raises
    ------
    fsmctl.errors.ResourceLimitError
        The estimate exceeds ``available``.

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base, check_campaign_memory
    >>> settings, base = campaign_base(CampaignSettings(runs=10**9))
    >>> try:
    ...     check_campaign_memory(settings, base, available=16 * 10**9)
    ... except ValueError as exc:
    ...     print(str(exc).split(" but")[0])
    montecarlo: the results of 1,000,000,000 runs would need ~... TB of memory
    """
    from fsmctl.simulation.simulator import available_memory

    per_run = RUN_RECORD_BYTES + 8 * len(PER_AGENT) * base.n_agents
    if available is None:
        available = available_memory()
    fit = max(0, int(available // (CAMPAIGN_MEMORY_FACTOR * per_run))) if available is not None else settings.runs
    return check_memory(
        f"montecarlo: the results of {settings.runs:,} runs",
        int(CAMPAIGN_MEMORY_FACTOR * per_run * settings.runs),
        available=available,
        advice=f"use --runs {fit:,} or fewer",
    )


# ----------------------------------------------------------------------------- the campaign


def run_campaign(
    settings: CampaignSettings,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    dask: Any = None,
    resume: bool = False,
    progress: bool | None = None,
    run_fn: RunFunction | None = None,
    figures: bool = True,
    base: Scenario | None = None,
    log: Callable[[str], None] | None = None,
    dask_timeout: float = DASK_TIMEOUT_S,
    command: Sequence[str] | str | None = None,
) -> CampaignResult:
    """Run (or resume) a Monte Carlo campaign and write ``out_dir``.

    Parameters
    ----------
    settings : CampaignSettings
        Scenario, number of runs, seed, perturbation bounds, horizon.
    out_dir : str or Path
        Receives ``campaign.json``, ``chunks/*.nc`` (one per chunk, written as soon as it is done),
        ``montecarlo.nc`` (all runs), ``summary.json``, ``histograms.png``/``.svg`` and, last,
        ``complete.json``.  Created if needed; removed again if the campaign ends before any chunk.
    workers : int, optional
        Local worker processes (1: in this process), never more than the chunks to run.  Default: one per CPU, at
        most one per chunk to run (:func:`fsmctl.policy.default_workers` of the number of chunks).  The results do
        not depend on it.
    dask : str or distributed.Client, optional
        Address of (or a client to) an existing Dask distributed cluster; replaces the local pool.
        An address must be one that distributed accepts (a scheme of one of its comm backends: ``tcp``,
        the default, ``tls``, ``inproc``, ``ws``, ...; ``host:port`` with the port for ``tcp``), else
        :class:`~fsmctl.errors.InputError` before any connection; a ``tcp://`` address must answer with a
        Dask handshake within ``dask_timeout``.
    resume : bool
        Continue a campaign already in ``out_dir`` (same settings), running only missing chunks.
    progress : bool, optional
        Progress bar (default: when stderr is a terminal).
    run_fn : callable, optional
        Replaces :func:`run_one` (same signature); used to test failure handling.
    figures : bool
        Write the histogram figure.
    base : Scenario, optional
        Use this scenario instead of loading ``settings.scenario``/``case`` (a :class:`Scenario` built in code).
    log : callable, optional
        Receives the lines of :func:`describe_campaign` before the first run (``fsmctl montecarlo`` prints them).
    dask_timeout : float
        Seconds a Dask scheduler gets to accept the connection and answer.
    command : sequence of str or str, optional
        The command line (``sys.argv``), embedded in ``montecarlo.nc`` with the base scenario, the law and the
        versions (:func:`fsmctl.simulation.results_io.provenance`).

    Returns
    -------
    CampaignResult
        The merged dataset, the summary and the files written.

    Raises
    ------
    fsmctl.errors.InputError
        A bad setting, a ``dask`` address that distributed does not accept, or ``out_dir`` holds another campaign.
    fsmctl.errors.EnvironmentProblem
        ``out_dir`` cannot be created or written (read-only, full), or ``dask`` is not a reachable scheduler.
    CampaignInterrupted
        ``SIGINT``/``SIGTERM`` (in the main thread): the workers were stopped and the finished chunks
        kept (``exc.detail`` says how many); ``exc.exit_code`` is 130 or 143.

    Examples
    --------
    Two runs of the paper's Case 1 on a 0.5 s horizon, in this process (a real campaign has hundreds of runs
    on the full horizon, ``fsmctl montecarlo``):

    >>> from fsmctl.studies import CampaignSettings, run_campaign
    >>> settings = CampaignSettings(runs=2, seed=1, t_final=0.5, steady_window=0.2, chunk_size=2)
    >>> result = run_campaign(settings, "campaign", workers=1, progress=False, figures=False)
    >>> result.summary["runs"], result.summary["ok"], result.failed_runs
    (2, 2, [])
    >>> sorted(p.name for p in result.out_dir.iterdir())
    ['campaign.json', 'chunks', 'complete.json', 'montecarlo.nc', 'summary.json']
    """
    settings.validate()
    if workers is not None:
        check_workers(workers, "run_campaign")
    t_start = time.perf_counter()
    out = Path(out_dir)
    with Runner(workers=1, dask=dask, dask_timeout=dask_timeout, name="montecarlo") as runner:
        if base is None:
            settings, base = campaign_base(settings)
        check_campaign(settings, base)
        check_campaign_memory(settings, base)
        if log is not None:
            for line in describe_campaign(settings, base):
                log(line)
        runner.start()  # a bad --dask is an error before the folder is touched
        folder = OutputFolder(out)
        total = n_chunks(settings)
        try:
            ident = campaign_record(settings, base)
            folder.prepare(ident, resume)
            todo = [
                c for c in range(total) if not (resume and existing_chunk(chunk_path(out, c), chunk_runs(settings, c)))
            ]
            resumed = total - len(todo)
            tasks = [chunk_task(base, settings, c, run_fn) for c in todo]
            runner.workers = min(resolve_workers(workers, len(todo), "run_campaign"), max(1, len(todo)))
            runner.progress(settings.runs, initial=settings.runs - sum(t.weight for t in tasks), enabled=progress)
            recorded = json.dumps(ident, allow_nan=False)  # what rebuilds campaign.json

            def on_chunk(task: Task, rows) -> None:  # in runner.deferred(): an interrupt waits for the file
                ds = chunk_dataset(rows, base.n_agents, settings.seed)
                ds.attrs["settings"] = recorded
                # an intermediate file: NetCDF-3, which the parent writes ~5x faster than compressed
                # NetCDF-4 (whose CPU time would compete with the workers'); montecarlo.nc is compressed
                write_dataset(ds, chunk_path(out, task.key), compress=False)

            runner.run(tasks, on_done=on_chunk)
            result = finish_campaign(out, settings, base, t_start, resumed, figures=figures, command=command)
        except BaseException as exc:
            runner.guard.closing()
            kept = folder.discard_if_empty()
            if isinstance(exc, CampaignInterrupted):
                exc.detail = (
                    f"{kept} of {total} chunk files kept in {out}; {RESUME_HINT}" if kept else "nothing was written"
                )
            raise
    return result


def _died(k: int, n_agents: int, message: str) -> list[tuple[int, str, str, dict]]:
    return [(k, STATUS_DIED, message, nan_record(n_agents))]


def chunk_task(base: Scenario, settings: CampaignSettings, c: int, run_fn: RunFunction | None = None) -> Task:
    """Chunk ``c`` as a task of the campaign runner: its rows (:func:`~fsmctl.studies.montecarlo.runs.run_chunk`).

    A chunk whose worker dies twice is run run by run (its :attr:`~fsmctl.studies.campaign.Task.parts`), each alone;
    a run that still kills its worker is reported ``worker-died``.

    Parameters
    ----------
    base : Scenario
        The base scenario.
    settings : CampaignSettings
        The campaign.
    c : int
        The chunk's number.
    run_fn : callable, optional
        Flies the runs one by one instead of together (see :func:`run_campaign`).

    Returns
    -------
    fsmctl.studies.campaign.Task
        The task (key ``c``, weight: its runs).

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base
    >>> from fsmctl.studies.montecarlo.run import chunk_task
    >>> settings, base = campaign_base(CampaignSettings(runs=5, chunk_size=2, t_final=0.5))
    >>> task = chunk_task(base, settings, 2)
    >>> task.key, task.weight, [part.args[2] for part in task.parts]
    (2, 1, [[4]])
    """
    idx = chunk_runs(settings, c)
    n = base.n_agents
    parts = tuple(
        Task((c, k), run_chunk, (base, settings, [k], run_fn), lost=functools.partial(_died, k, n)) for k in idx
    )
    return Task(c, run_chunk, (base, settings, idx, run_fn), weight=len(idx), parts=parts)
