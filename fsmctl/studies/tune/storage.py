"""A study's journal (``study.log``): its lock, buffered writes, the seeded samplers, proposing and telling trials."""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import os
import socket
import stat
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import EnvironmentProblem, InputError
from fsmctl.studies.tune.evaluation import Snapshot
from fsmctl.studies.tune.settings import POPULATION, TuneSettings

# ----------------------------------------------------------------------------- the search


LOCK_WAIT_S = 30.0
"""seconds a lock on ``study.log`` held by a live process is waited for before the study is refused"""

STALE_LOCK_S = 10.0
"""a lock on ``study.log`` that names no process of this host (Optuna's own symlink lock, a lock from another host,
or an unreadable one) is broken once it is this old: a write holds the lock for milliseconds"""

_log = logging.getLogger(__name__)


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    except OSError:
        return True
    return True


class _JournalLock:
    """The lock of ``study.log`` (an Optuna ``BaseJournalFileLock``): ``study.log.lock``, created exclusively and
    holding ``<pid> <host>`` of its holder, always at the journal's absolute path.

    Optuna's default lock is a symbolic link to the journal's path as given: for a relative ``--out`` it dangles
    (``out/study.log`` seen from ``out/``), and a lock left by a killed process then made the next ``--resume``
    spin at 100 % CPU without a word (the link's ``stat`` fails and the wait loop retries at once); for an absolute
    one it waited a silent 31 s.  Here a lock whose holder is a dead process of this host is broken at once, one of
    unknown holder once it is :data:`STALE_LOCK_S` old (both with a warning), and a live holder is waited for
    :data:`LOCK_WAIT_S`, then :class:`~fsmctl.errors.InputError` names it.
    """

    def __init__(self, journal: Path):
        self.path = Path(str(journal.absolute()) + ".lock")

    def _holder(self) -> tuple[str | None, str | None]:
        """``(None, None)`` while the lock is held by a live process (or is gone), else ``(None, why it is stale)``;
        ``(holder, None)`` names a live holder."""
        try:
            st = os.lstat(self.path)
        except FileNotFoundError:
            return None, None
        pid = host = None
        if stat.S_ISREG(st.st_mode):
            with contextlib.suppress(OSError, ValueError):
                text = self.path.read_text(encoding="utf-8").split()
                pid, host = int(text[0]), text[1]
        if pid is not None and host == socket.gethostname():
            if not _process_alive(pid):
                return None, f"its holder, process {pid}, is no longer running"
            return f"process {pid}", None
        age = time.time() - st.st_mtime
        if age > STALE_LOCK_S:
            owner = f"process {pid} on {host}" if pid is not None else "no process of this host"
            return None, f"it names {owner} and is {age:.0f} s old (a write holds it for milliseconds)"
        return (f"process {pid} on {host}" if pid is not None else "an unknown process"), None

    def acquire(self) -> bool:
        """Create the lock (blocking); break a stale one; :class:`~fsmctl.errors.InputError` after
        :data:`LOCK_WAIT_S` of a live holder."""
        record = f"{os.getpid()} {socket.gethostname()}\n".encode()
        deadline = time.monotonic() + LOCK_WAIT_S
        while True:
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                pass
            else:
                try:
                    os.write(fd, record)
                finally:
                    os.close(fd)
                return True
            holder, stale = self._holder()
            if stale is not None:
                _log.warning("tune: removed the stale lock %s: %s", self.path, stale)
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.path)
                continue
            if holder is not None and time.monotonic() > deadline:
                raise InputError(
                    f"tune: {self.path} has been held by {holder} for over {LOCK_WAIT_S:g} s (another fsmctl tune on "
                    "this study?): wait for it to end, or remove the lock if that process is not fsmctl"
                )
            time.sleep(0.01)

    def release(self) -> None:
        """Remove the lock."""
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)


def _check_journal(path: Path) -> None:
    """:class:`~fsmctl.errors.InputError` naming the file and line when ``study.log`` holds a line that is not a
    journal record (a JSON object on a line of its own), instead of Optuna's ``JSONDecodeError``."""
    try:
        with open(path, "rb") as fh:
            for number, line in enumerate(fh, start=1):
                problem = None
                if not line.endswith(b"\n"):
                    problem = "it is cut short (no end of line)"
                else:
                    try:
                        record = json.loads(line)
                    except ValueError as exc:
                        problem = f"not JSON: {exc}"
                    else:
                        if not isinstance(record, dict) or "op_code" not in record:
                            problem = "not an Optuna journal operation"
                if problem is not None:
                    raise InputError(
                        f"tune: {path}: line {number} is not a journal record ({problem}); the study's journal is "
                        "damaged: restore it, or start afresh in another --out"
                    )
    except FileNotFoundError:
        return
    except OSError as exc:
        raise EnvironmentProblem(exc.errno or errno.EIO, f"tune: cannot read {path}: {exc.strerror or exc}") from None


class BufferedJournal:
    """Optuna's journal file (``JournalFileBackend``) whose writes inside :meth:`buffered` are appended at once.

    ``JournalStorage`` appends one log (one locked write and one ``fsync``) per operation, about 15 per trial, and
    reads every log back; on a busy disk the ``fsync`` calls cost milliseconds each and dominated a long study.
    Inside :meth:`buffered` (a batch's proposals, a batch's results) the logs wait in memory, where
    :meth:`read_logs` serves them after those in the file, and leave in one write when the block ends, so the journal
    gains a batch's proposals or results whole (an interrupt waits for the block to end:
    :meth:`fsmctl.parallel.InterruptGuard.deferred`).  This process is the journal's only writer.
    """

    def __init__(self, path: Path):
        from optuna.storages.journal import JournalFileBackend

        path = Path(path).absolute()
        _check_journal(path)
        self._file = JournalFileBackend(str(path), lock_obj=_JournalLock(path))
        self._buffer: list[dict[str, Any]] = []
        self._on_disk: int | None = None
        """logs in the file (learnt at the first read; this process is its only writer)"""
        self._buffering = False

    def read_logs(self, log_number_from: int) -> list[dict[str, Any]]:
        """The logs numbered ``log_number_from`` on (``optuna.storages.journal.BaseJournalBackend``): the file's, then
        the buffered ones.  The file is read once (``JournalStorage`` reads on from where it stopped, and this process
        writes everything after that)."""
        if self._on_disk is not None and log_number_from >= self._on_disk:
            return self._buffer[log_number_from - self._on_disk :]
        logs = list(self._file.read_logs(log_number_from))
        if self._on_disk is None:
            self._on_disk = log_number_from + len(logs)
        return logs + self._buffer[max(0, log_number_from - self._on_disk) :]

    def append_logs(self, logs: list[dict[str, Any]]) -> None:
        """Append ``logs`` (``optuna.storages.journal.BaseJournalBackend``): to the buffer inside :meth:`buffered`."""
        if self._on_disk is None:
            self.read_logs(0)  # learn the file's length first
        if self._buffering:
            self._buffer.extend(logs)
        else:
            self._file.append_logs(logs)
            self._on_disk += len(logs)

    def flush(self) -> None:
        if self._buffer:
            logs, self._buffer = self._buffer, []
            self._file.append_logs(logs)
            self._on_disk += len(logs)

    @contextlib.contextmanager
    def buffered(self):
        """Logs written inside the block are appended to the file in one write when it ends."""
        self._buffering = True
        try:
            yield
        finally:
            self._buffering = False
            self.flush()


def trial_seed(seed: int, index: int) -> int:
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint32)[0])


def trial_sampler(n_objectives: int, seed: int, previous=None):
    """The sampler of one trial, seeded from ``(seed, index)``.

    Optuna >= 5: the samplers read the constraints a trial sets (``Trial.set_constraint``).  TPE's search space
    (the intersection of the told trials' distributions, the same for every trial here) is carried over from the
    previous trial's sampler, which it caches incrementally: recomputing it over every told trial for each new
    sampler would cost O(trials) per trial (about a quarter of the sampler's time at 2500 trials).
    """
    import optuna

    if n_objectives > 1:
        return optuna.samplers.NSGAIISampler(seed=seed, population_size=POPULATION)
    sampler = optuna.samplers.TPESampler(seed=seed)
    cache = getattr(previous, "_search_space", None)
    if cache is not None and hasattr(sampler, "_search_space"):
        sampler._search_space = cache
    return sampler


def counted_trial(trial) -> bool:
    from optuna.trial import TrialState

    if trial.state in (TrialState.COMPLETE, TrialState.PRUNED):
        return True
    return trial.state == TrialState.FAIL and "simulation_error" in trial.user_attrs


def pruner_snapshot(trials: Sequence, before: int) -> Snapshot:
    """What the pruner may see: the told (complete or pruned) trials with an index below ``before``."""
    from optuna.trial import TrialState

    return tuple(
        (t.number, t.state.name, intermediate_values(t), dict(t.user_attrs.get("pruner", {})))
        for t in trials
        if t.state in (TrialState.COMPLETE, TrialState.PRUNED) and t.user_attrs.get("index", -1) < before
    )


def intermediate_values(trial) -> dict[int, float]:
    """A told trial's intermediate values by step (:data:`CHECKPOINTS`), from its ``intermediate`` user attribute.

    Every step's value is kept there (one journal write); Optuna's own ``intermediate_values`` are reported only for
    pruned trials (the last one is how Optuna's samplers rank a pruned trial), which keeps a study of thousands of
    trials from spending its time on journal writes.

    Parameters
    ----------
    trial : optuna.trial.FrozenTrial
        A trial of a ``fsmctl tune`` study (``study.log``).

    Returns
    -------
    dict
        Step -> value; empty without a pruner.
    """
    return {int(k): float(v) for k, v in trial.user_attrs.get("intermediate", {}).items()}


def tell_trial(study, trial_id: int, result: dict, constraints: Sequence[str], n_objectives: int) -> None:
    """Record one evaluated trial in the journal (intermediate values, constraints, attributes, then its state)."""
    from optuna.trial import Trial, TrialState

    trial = Trial(study, trial_id)
    steps = sorted(result["intermediate"].items())
    if steps:
        trial.set_user_attr("intermediate", {str(k): float(v) for k, v in steps})
    if result["state"] == "pruned":
        for step, value in steps:
            trial.report(float(value), int(step))
    for name in constraints:
        if name in result["constraints"]:
            trial.set_constraint(name, float(result["constraints"][name]))
    if result["pruner_attrs"]:
        trial.set_user_attr("pruner", result["pruner_attrs"])
    if len(result["members"]) > 1:  # one member: its scores are the trial's
        trial.set_user_attr("members", result["members"])
    if result["state"] == "pruned":
        trial.set_user_attr("pruned_at", result["pruned_at"])
        study.tell(trial, state=TrialState.PRUNED)
    elif result["state"] == "failed":
        trial.set_user_attr("simulation_error", result["error"])
        study.tell(trial, state=TrialState.FAIL)
    else:
        study.tell(trial, list(result["objectives"][:n_objectives]))


def trial_rows(trials: Sequence, space, settings: TuneSettings, constraints: Sequence[str]) -> list[dict]:
    from optuna.trial import TrialState

    rows = []
    for index, t in enumerate(trials):
        complete = t.state == TrialState.COMPLETE
        state = "complete" if complete else ("pruned" if t.state == TrialState.PRUNED else "failed")
        given = t.constraints
        cons = {c: float(given[c]) for c in constraints if c in given}
        rows.append(
            {
                "index": index,
                "state": state,
                "feasible": complete and len(cons) == len(constraints) and all(v <= 0 for v in cons.values()),
                "params": {p.name: float(t.params[p.name]) for p in space if p.name in t.params},
                "objectives": dict(zip(settings.objectives, t.values, strict=True)) if complete else {},
                "constraints": cons,
                "pruned_at": t.user_attrs.get("pruned_at"),
                "error": t.user_attrs.get("simulation_error", ""),
            }
        )
    return rows


def pending_trials(study, storage, space, told: int, batch: int, budget: int) -> dict[int, tuple[int, dict]]:
    """The proposed, not yet told trials of the unfinished batch (resumed as proposed); others in flight are failed.

    Trials are proposed and told in index order, so the ones to resume are the indices ``told, told + 1, ...`` of the
    batch of ``told``; a trial cut off while it was being proposed (no index, missing parameters) is failed and
    proposed again.
    """
    from optuna.trial import TrialState

    start = (told // batch) * batch
    names = {p.name for p in space}
    pending: dict[int, tuple[int, dict]] = {}
    stale = []
    running = [t for t in study.get_trials(deepcopy=False) if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    for t in sorted(running, key=lambda t: t.user_attrs.get("index", -1)):
        j = t.user_attrs.get("index")
        ok = isinstance(j, int) and set(t.params) == names and told <= j < min(start + batch, budget)
        if ok and j == told + len(pending):
            pending[j] = (t._trial_id, {p.name: float(t.params[p.name]) for p in space})
        else:
            stale.append(t)
    for t in stale:
        storage.set_trial_state_values(t._trial_id, TrialState.FAIL)
    return pending
