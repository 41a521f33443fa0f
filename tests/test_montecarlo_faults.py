"""Monte Carlo campaigns under faults: signals, dead parents, non-Dask endpoints, unusable output folders.

Also the campaign's inputs and outputs that the faults exposed: scenario files without ``[cases]``, every
sampling range an option with its default, a link-weight default that keeps Theorem 1 satisfiable,
"final" values taken at ``t_final``, strict JSON.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from fsmctl.errors import EnvironmentProblem, InputError
from fsmctl.studies import montecarlo as mc

psutil = pytest.importorskip("psutil")

CLI = [sys.executable, "-m", "fsmctl.cli.main", "montecarlo"]
TINY = ["--runs", "1", "--t-final", "0.1", "--workers", "1", "--no-progress"]
# chunks of 2 runs of the 100 s paper horizon (~0.5 s per run): long enough to signal mid-campaign


def _long(runs: int) -> list[str]:
    return ["--runs", str(runs), "--chunk-size", "2", "--t-final", "100", "--workers", "2", "--no-progress"]


def _one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def _chunk_files(out: Path) -> list[Path]:
    return sorted((out / "chunks").glob("chunk_*.nc"))


def _start_mid_campaign(out: Path, runs: int = 12) -> tuple[subprocess.Popen, list]:
    """A running ``fsmctl montecarlo`` (own process group) with its first chunk written; its descendants."""
    proc = subprocess.Popen(
        [*CLI, *_long(runs), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not _chunk_files(out):
        if proc.poll() is not None or time.monotonic() > deadline:
            _kill_tree(proc, [])
            pytest.fail(f"campaign ended or stalled before its first chunk: {proc.returncode} {proc.stderr.read()}")
        time.sleep(0.05)
    workers = psutil.Process(proc.pid).children(recursive=True)
    assert len(workers) >= 2, workers  # two workers (and multiprocessing's resource tracker)
    return proc, workers


def _kill_tree(proc: subprocess.Popen, descendants: list) -> None:
    with contextlib.suppress(Exception):
        proc.kill()
        proc.wait(5)
    for p in descendants:
        with contextlib.suppress(psutil.Error):
            p.kill()


def _gone_within(procs: list, seconds: float) -> list[int]:
    _, alive = psutil.wait_procs(procs, timeout=seconds)
    return [p.pid for p in alive]


# ----------------------------------------------------------------------------- signals


@pytest.mark.parametrize(
    ("signame", "to_group", "exit_code", "runs", "resume"),
    [
        # `kill PID`: orderly shutdown, exit 128 + 15, then --resume completes the campaign
        ("SIGTERM", False, 143, 12, True),
        # Ctrl-C in a terminal reaches the whole process group; ~10 s of queued work must not be waited for
        ("SIGINT", True, 130, 40, False),
    ],
    ids=["sigterm-then-resume", "ctrl-c-to-process-group"],
)
def test_signal_stops_workers_keeps_chunks(tmp_path, signame, to_group, exit_code, runs, resume):
    out = tmp_path / "mc"
    proc, workers = _start_mid_campaign(out, runs)
    try:
        sig = getattr(signal, signame)
        if to_group:
            os.killpg(proc.pid, sig)
        else:
            os.kill(proc.pid, sig)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=30)
        assert time.monotonic() - t0 < 5, "the queued chunks were waited for instead of cancelled"
        assert proc.returncode == exit_code, err
        assert _gone_within(workers, 5) == [], "workers outlived the campaign"
        line = _one_line(err)
        assert signame in line and "kept" in line and "--resume" in line and "resume=True" in line, line
        kept = {p.name: p.read_bytes() for p in _chunk_files(out)}
        assert 1 <= len(kept) < runs // 2 and not (out / mc.COMPLETE_MARKER).exists()
    finally:
        _kill_tree(proc, workers)
    if not resume:
        return
    done = subprocess.run(
        [*CLI, *_long(runs), "--out", str(out), "--resume"], capture_output=True, text=True, timeout=240
    )
    assert done.returncode == 0, done.stderr
    assert f"({len(kept)} chunks resumed)" in done.stdout
    with xr.open_dataset(out / "montecarlo.nc") as ds:
        assert ds.run.values.tolist() == list(range(runs))  # every run exactly once
        assert set(ds.status.values.tolist()) == {"ok"}
    for name, data in kept.items():  # the kept chunks were not run again
        assert (out / "chunks" / name).read_bytes() == data
    assert json.loads((out / mc.COMPLETE_MARKER).read_text())["runs"] == runs


def test_sigkill_of_the_campaign_ends_its_workers(tmp_path):
    proc, workers = _start_mid_campaign(tmp_path / "mc")
    try:
        proc.kill()  # SIGKILL: no handler runs in the parent
        proc.wait(10)
        assert _gone_within(workers, 5) == [], "workers outlived a killed parent"
    finally:
        _kill_tree(proc, workers)


_ORPHAN_SCRIPT = """
import multiprocessing, os, sys, time
from fsmctl import parallel
if sys.argv[1] == "watchdog":
    parallel._set_parent_death_signal = lambda signum: False  # only the portable fallback is left
# pdeathsig: a watchdog that would wake after an hour, so the kernel's signal alone must end the child
period = 3600.0 if sys.argv[1] == "pdeathsig" else parallel.WATCHDOG_PERIOD_S
parent = os.getpid()
ctx = multiprocessing.get_context("fork")
ready = ctx.Event()
def child():
    parallel.worker_lifeline(parent, period)
    ready.set()
    time.sleep(120)
p = ctx.Process(target=child)
p.start()
print(p.pid if ready.wait(30) else "the child's initializer failed", flush=True)
time.sleep(120)
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
@pytest.mark.parametrize("mechanism", ["pdeathsig", "watchdog"])
def test_worker_lifeline_ends_an_orphaned_worker(mechanism):
    """A worker initialized by worker_lifeline dies when its parent is SIGKILLed: by prctl alone, or by the watchdog alone."""
    if mechanism == "pdeathsig" and not sys.platform.startswith("linux"):
        pytest.skip("PR_SET_PDEATHSIG is Linux-only")
    parent = subprocess.Popen(
        [sys.executable, "-c", _ORPHAN_SCRIPT, mechanism], stdout=subprocess.PIPE, text=True, start_new_session=True
    )
    child = None
    try:
        line = parent.stdout.readline().strip()
        assert line.isdigit(), line
        child = psutil.Process(int(line))  # its initializer has run
        assert child.status() != psutil.STATUS_ZOMBIE
        parent.kill()
        parent.wait(10)
        assert _gone_within([child], 3) == []
    finally:
        _kill_tree(parent, [child] if child is not None else [])


_TIME_LIMITED_SCRIPT = """
import os, sys, time
from fsmctl.parallel import run_with_time_limit
def slow():
    print(os.getpid(), flush=True)  # the child's pid, for the test to watch
    time.sleep(120)
run_with_time_limit(slow, 300.0)
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_computation_under_a_time_limit_dies_with_its_parent():
    """``fsmctl prove``'s uninterruptible SymPy steps run in a child under a time limit: a SIGKILL of the parent ends
    the child too (it used to run on, a daemon only for a parent that exits normally, up to the limit)."""
    parent = subprocess.Popen(
        [sys.executable, "-c", _TIME_LIMITED_SCRIPT], stdout=subprocess.PIPE, text=True, start_new_session=True
    )
    child = None
    try:
        line = parent.stdout.readline().strip()
        assert line.isdigit(), line
        child = psutil.Process(int(line))
        assert child.ppid() == parent.pid and child.status() != psutil.STATUS_ZOMBIE
        parent.kill()
        parent.wait(10)
        assert _gone_within([child], 3) == []
    finally:
        _kill_tree(parent, [child] if child is not None else [])


# ----------------------------------------------------------------------------- Dask endpoints


class _FakeEndpoint:
    """A TCP server on 127.0.0.1 that answers every connection with ``reply`` (None: says nothing, b"": closes)."""

    def __init__(self, reply: bytes | None, lifetime_s: float = 40.0):
        self.reply = reply
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(0.1)
        self.port = self.sock.getsockname()[1]
        self.deadline = time.monotonic() + lifetime_s
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)

    def _serve(self) -> None:
        conns = []
        try:
            while not self.stop.is_set() and time.monotonic() < self.deadline:  # bounded
                try:
                    conn, _ = self.sock.accept()
                except TimeoutError:
                    continue
                if self.reply == b"":
                    conn.close()
                    continue
                conns.append(conn)
                if self.reply:
                    with contextlib.suppress(OSError):
                        conn.sendall(self.reply)
        finally:
            for conn in conns:
                conn.close()
            self.sock.close()

    def __enter__(self) -> _FakeEndpoint:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.thread.join(5)


@pytest.mark.parametrize(
    "reply",
    [
        b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",  # exabytes in Dask's framing
        b"\x00\x00\x00\x00\x10\x00\x00\x00" + b"\x01" * 64,  # a 64 GiB length prefix, then nothing more
        None,  # accepts and says nothing
        b"",  # accepts and closes
    ],
    ids=["http", "huge-length", "silent", "closes"],
)
def test_non_dask_endpoint_is_one_line_exit_2_in_bounded_time(tmp_path, capsys, reply):
    from fsmctl.cli.main import main

    out = tmp_path / "out"
    with _FakeEndpoint(reply) as server:
        t0 = time.monotonic()
        code = main(
            ["montecarlo", *TINY, "--out", str(out), "--dask", f"tcp://127.0.0.1:{server.port}", "--dask-timeout", "2"]
        )
        elapsed = time.monotonic() - t0
    err = capsys.readouterr().err
    assert code == 2 and elapsed < 15, (code, elapsed, err)
    assert "not a Dask scheduler" in _one_line(err)
    assert not out.exists()  # nothing was written, so no folder either


BAD_ADDRESSES = {
    "http-scheme": "http://127.0.0.1:8786",
    "unknown-scheme": "foo://x",
    "bare-word": "scheduler",  # distributed's tcp default, but without the port distributed requires
    "tcp-without-port": "tcp://127.0.0.1",
    "inproc-syntax": "inproc://x",
}


@pytest.mark.parametrize("address", list(BAD_ADDRESSES.values()), ids=list(BAD_ADDRESSES))
def test_address_distributed_refuses_is_input_error_before_any_connection(tmp_path, address):
    """What distributed's address parsing and comm backends refuse is an InputError naming the address."""
    pytest.importorskip("distributed")
    out = tmp_path / "out"
    with pytest.raises(InputError, match="not a scheduler address") as info:
        mc.run_campaign(mc.CampaignSettings(runs=1, t_final=0.1), out, dask=address, progress=False, figures=False)
    assert f"--dask {address}:" in str(info.value)
    assert not out.exists()


@pytest.mark.parametrize("address", ["http://127.0.0.1:8786", "foo://x", "scheduler"], ids=["http", "foo", "bare"])
def test_cli_address_of_a_wrong_scheme_is_one_line_exit_2_at_once(tmp_path, address):
    """Was: a half-started distributed.Client whose finalizer waited 2 x --dask-timeout, then a traceback."""
    pytest.importorskip("distributed")
    t0 = time.monotonic()
    proc = subprocess.run(
        [*CLI, *TINY, "--out", str(tmp_path / "out"), "--dask", address],  # the default --dask-timeout: 10 s
        capture_output=True,
        text=True,
        timeout=120,
    )
    elapsed = time.monotonic() - t0
    assert proc.returncode == 2, proc.stderr
    assert "not a scheduler address" in _one_line(proc.stderr)
    assert elapsed < 10, elapsed  # the finalizer alone took 20 s


def test_tls_without_certificates_is_one_line_exit_2_at_once(tmp_path):
    """A scheme distributed serves but cannot use here (no TLS context configured): one line, no finalizer wait."""
    pytest.importorskip("distributed")
    with socket.create_server(("127.0.0.1", 0)) as server:
        address = f"tls://127.0.0.1:{server.getsockname()[1]}"
        with pytest.raises(EnvironmentProblem, match=r"cannot connect to a Dask scheduler.*TLS"):
            mc.run_campaign(
                mc.CampaignSettings(runs=1, t_final=0.1), tmp_path / "lib", dask=address, progress=False, figures=False
            )
        t0 = time.monotonic()
        proc = subprocess.run(
            [*CLI, *TINY, "--out", str(tmp_path / "out"), "--dask", address],
            capture_output=True,
            text=True,
            timeout=120,
        )
        elapsed = time.monotonic() - t0
    assert proc.returncode == 2 and "TLS" in _one_line(proc.stderr)
    assert elapsed < 10, elapsed  # the finalizer alone took 20 s


# ----------------------------------------------------------------------------- output folders


def _read_only_place(tmp_path: Path) -> Path:
    if os.geteuid() == 0:  # root ignores permission bits; sysfs refuses new folders even to root
        return Path("/sys/fsmctl-montecarlo-test/out")
    ro = tmp_path / "read-only"
    ro.mkdir()
    ro.chmod(0o555)
    return ro / "out"


@pytest.mark.parametrize("where", ["inside-dev-full", "dev-full", "read-only"])
def test_unusable_output_folder_is_environment_problem(tmp_path, capsys, where):
    from fsmctl.cli.main import main

    out = {
        "inside-dev-full": Path("/dev/full/x"),
        "dev-full": Path("/dev/full"),
        "read-only": _read_only_place(tmp_path),
    }[where]
    settings = mc.CampaignSettings(runs=1, t_final=0.1)
    with pytest.raises(EnvironmentProblem, match="cannot create the output folder"):
        mc.run_campaign(settings, out, workers=1, progress=False, figures=False)
    code = main(["montecarlo", *TINY, "--out", str(out)])
    assert code == 2 and str(out) in _one_line(capsys.readouterr().err)


@pytest.mark.skipif(sys.platform == "win32", reason="RLIMIT_FSIZE")
@pytest.mark.parametrize("max_file_bytes", [300, 3000], ids=["campaign.json-does-not-fit", "first-chunk-does-not-fit"])
def test_full_device_is_one_line_and_leaves_no_folder(tmp_path, max_file_bytes):
    """Writes beyond RLIMIT_FSIZE fail like a full device (Python ignores SIGXFSZ, so write() gets EFBIG)."""
    import resource

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (max_file_bytes, max_file_bytes))

    out = tmp_path / "new" / "campaign"
    proc = subprocess.run(
        [*CLI, *TINY, "--out", str(out)], capture_output=True, text=True, timeout=120, preexec_fn=limit
    )
    assert not (tmp_path / "new").exists()  # the folders it created are gone again
    assert proc.returncode == 2
    assert "cannot write" in _one_line(proc.stderr)


# ----------------------------------------------------------------------------- a damaged campaign.json

RESUMABLE = {"runs": 6, "seed": 5, "t_final": 0.3, "chunk_size": 2, "output_interval": 0.1, "steady_window": 0.1}


def _campaign(out: Path, resume: bool = False, **kw) -> mc.CampaignResult:
    settings = mc.CampaignSettings(**{**RESUMABLE, **kw})
    return mc.run_campaign(settings, out, workers=1, progress=False, figures=False, resume=resume)


def _without_timings(ds: xr.Dataset) -> xr.Dataset:
    return ds.drop_vars(list(mc.TIMING_VARIABLES))


@pytest.fixture(scope="module")
def finished_campaign(tmp_path_factory) -> tuple[Path, mc.CampaignResult]:
    out = tmp_path_factory.mktemp("finished") / "campaign"
    return out, _campaign(out)


@pytest.fixture
def interrupted_campaign(tmp_path, finished_campaign) -> Path:
    """A copy of the finished campaign as an interrupt leaves it: the last chunk and the merged files missing."""
    import shutil

    out = tmp_path / "campaign"
    shutil.copytree(finished_campaign[0], out)
    for name in ("chunks/chunk_00002.nc", "montecarlo.nc", "summary.json", "complete.json"):
        (out / name).unlink()
    return out


DAMAGES = {
    "truncated": lambda text: text[: len(text) // 2],
    "empty": lambda text: "",
    "not-an-object": lambda text: "[1, 2]\n",
    "not-utf8": lambda text: "\udcff",
    "missing": None,
}


@pytest.mark.parametrize("damage", list(DAMAGES), ids=list(DAMAGES))
def test_damaged_campaign_json_is_rebuilt_from_the_chunk_files(interrupted_campaign, finished_campaign, damage, caplog):
    """Was: "holds a campaign with different settings" (and chunk files without campaign.json: choose another --out)."""
    out = interrupted_campaign
    meta = out / "campaign.json"
    original = meta.read_text(encoding="utf-8")
    if DAMAGES[damage] is None:
        meta.unlink()
    else:
        meta.write_bytes(DAMAGES[damage](original).encode("utf-8", "surrogateescape"))
    with pytest.raises(InputError, match="--resume"):  # a folder with a campaign still needs --resume
        _campaign(out)
    with caplog.at_level("WARNING", logger="fsmctl"):
        resumed = _campaign(out, resume=True)
    assert resumed.resumed_chunks == 2
    xr.testing.assert_identical(_without_timings(resumed.dataset), _without_timings(finished_campaign[1].dataset))
    assert json.loads(meta.read_text(encoding="utf-8")) == json.loads(original)
    warning = " ".join(r.getMessage() for r in caplog.records if r.levelname == "WARNING")
    assert str(meta) in warning and ("damaged" if damage != "missing" else "missing") in warning
    assert "rebuilt from the 2 chunk files" in warning


def test_damaged_campaign_json_and_chunks_of_other_settings_is_one_line(interrupted_campaign, capsys):
    from fsmctl.cli.main import main

    meta = interrupted_campaign / "campaign.json"
    meta.write_text(meta.read_text(encoding="utf-8")[:40], encoding="utf-8")
    with pytest.raises(InputError, match=r"is damaged \(not valid JSON.*chunk_00000.nc: seed\)"):
        _campaign(interrupted_campaign, seed=99, resume=True)
    argv = ["--runs", "6", "--seed", "99", "--t-final", "0.3", "--chunk-size", "2", "--output-interval", "0.1"]
    code = main(
        ["montecarlo", *argv, "--workers", "1", "--no-progress", "--out", str(interrupted_campaign), "--resume"]
    )
    line = _one_line(capsys.readouterr().err)
    assert code == 2 and f"{meta} is damaged" in line and "different settings" in line


def test_damaged_campaign_json_and_chunks_that_record_nothing_says_what_to_do(interrupted_campaign):
    """Chunk files of an older fsmctl do not record the settings: nothing to check the campaign against."""
    meta = interrupted_campaign / "campaign.json"
    damaged = meta.read_text(encoding="utf-8")[:-30]
    meta.write_text(damaged, encoding="utf-8")
    chunk = interrupted_campaign / "chunks" / "chunk_00001.nc"
    with xr.open_dataset(chunk) as ds:
        old = ds.load()
    del old.attrs["settings"]
    chunk.unlink()
    old.to_netcdf(chunk, format="NETCDF3_64BIT")
    with pytest.raises(InputError, match=r"is damaged.*do not record the campaign's settings.*another --out"):
        _campaign(interrupted_campaign, resume=True)
    assert meta.read_text(encoding="utf-8") == damaged  # left as it was


def test_damaged_campaign_json_without_chunks_starts_afresh(tmp_path, finished_campaign):
    out = tmp_path / "campaign"
    (out / "chunks").mkdir(parents=True)
    (out / "campaign.json").write_text('{"runs": 6, "se', encoding="utf-8")
    result = _campaign(out, resume=True)
    assert result.resumed_chunks == 0 and result.summary["runs"] == 6
    xr.testing.assert_identical(_without_timings(result.dataset), _without_timings(finished_campaign[1].dataset))


# ----------------------------------------------------------------------------- inputs and outputs


def test_scenario_without_cases_runs_and_settings_are_printed_and_stored(tmp_path):
    text = (Path(mc.__file__).parents[2] / "scenarios" / "paper.toml").read_text()
    no_cases = tmp_path / "single.toml"
    no_cases.write_text(text[: text.index("[cases.")])
    out = tmp_path / "out"
    proc = subprocess.run(
        [*CLI, "--scenario", str(no_cases), "--runs", "2", "--t-final", "0.2", "--workers", "1", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    head = proc.stdout.splitlines()
    assert head[0].startswith("montecarlo: paper: 6 agents")  # no case in the label
    for option in ("--attitude-bound-deg", "--rate-bound", "--inertia-bound", "--coupling-high", "--link-dropout"):
        assert any(option in line for line in head[:10]), option
    assert "2 ok, 0 failed" in proc.stdout
    summary = json.loads((out / "summary.json").read_text())
    stored = json.loads((out / "campaign.json").read_text())
    assert summary["settings"] == stored and stored["case"] is None and stored["coupling_high"] == 1.0
    with xr.open_dataset(out / "montecarlo.nc") as ds:
        assert json.loads(ds.attrs["settings"]) == stored
    assert (out / mc.COMPLETE_MARKER).is_file()


def test_every_sampling_range_is_an_option_with_its_default(capsys):
    from fsmctl.cli.main import build_parser

    expected = {  # field -> default, written out here independently of the module's table
        "attitude_bound_deg": 180.0,
        "rate_bound": 0.5,
        "inertia_bound": 0.3,
        "disturbance_scale": 1.0,
        "link_dropout": 0.2,
        "coupling_low": 0.5,
        "coupling_high": 1.0,
    }
    d = mc.CampaignSettings()
    assert {name for name, _ in mc.SAMPLING_RANGES} == set(expected)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["montecarlo", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name, default in expected.items():
        flag = "--" + name.replace("_", "-")
        assert getattr(d, name) == default
        after = text.split(f"{flag} {name.upper()} ", 1)[1]
        assert after.split(" --", 1)[0].endswith(f"(default: {default})"), (flag, after[:300])
    assert "(default: its first case" in text and "130 (SIGINT) or 143 (SIGTERM)" in text


def test_default_link_weights_keep_theorem1(paper_case1):
    """k^j factors up to 1 keep k^i >= k^j (eq 27) on every link; the former 1.7 broke it in most runs."""
    from fsmctl.proofs.theorem1 import analyze_topology

    d = mc.CampaignSettings()
    assert d.coupling_high <= 1.0 < mc.theorem1_factor_limit(paper_case1.topology)

    def holds(settings: mc.CampaignSettings, k: int) -> tuple[bool, bool]:
        run = mc.sample_run_scenario(paper_case1, settings, np.random.SeedSequence(11).spawn(k + 1)[k])
        per_link = all(link.k_i >= link.k_j.max for link in run.topology.links)
        return per_link, analyze_topology(run.topology, 100.0).holds

    default = [holds(d, k) for k in range(16)]
    assert all(p for p, _ in default) and sum(h for _, h in default) >= 14
    wide = [holds(dataclasses.replace(d, coupling_high=1.7), k) for k in range(16)]
    assert sum(h for _, h in wide) <= 8  # negative control: the old range


def test_final_values_are_at_t_final(tmp_path):
    """The campaign's own output grid (0.1 s requested) is lowered to divide t_final = 0.25 s."""
    from fsmctl.simulation.simulator import simulate

    s = mc.CampaignSettings(runs=1, seed=3, t_final=0.25, output_interval=0.1)
    _, base = mc.campaign_base(s)
    assert math.isclose(base.simulation.output_interval, 0.05)
    res = mc.run_campaign(s, tmp_path / "o", workers=1, progress=False, figures=False)
    assert res.dataset.status.values.tolist() == ["ok"]
    fine = simulate(
        mc.sample_run_scenario(base, s, np.random.SeedSequence(3).spawn(1)[0]).replace(
            simulation={"output_interval": 0.001}
        ),
        progress=False,
    )
    assert math.isclose(fine.time[-1], 0.25)
    assert float(res.dataset.aaem_final_deg[0]) == pytest.approx(float(fine.aaem_deg[-1]), rel=1e-9)


def test_result_not_ending_at_t_final_is_failed_not_ok(tmp_path, monkeypatch):
    import fsmctl.simulation.simulator as simulator

    real = simulator.simulate

    def early(scenario, **kw):  # a grid that stops one sample short of t_final
        r = real(scenario, **kw)
        return dataclasses.replace(r, time=r.time - scenario.simulation.output_interval)

    real_many = simulator.simulate_many

    def early_many(scenarios, **kw):  # the same, for the runs of a chunk flown together
        scenarios = list(scenarios)
        return [
            early(s) if not isinstance(r, Exception) else r
            for s, r in zip(scenarios, real_many(scenarios, **kw), strict=True)
        ]

    monkeypatch.setattr(simulator, "simulate", early)
    monkeypatch.setattr(simulator, "simulate_many", early_many)
    res = mc.run_campaign(
        mc.CampaignSettings(runs=1, t_final=0.2), tmp_path / "o", workers=1, progress=False, figures=False
    )
    assert res.dataset.status.values.tolist() == ["failed"]
    assert "t_final" in str(res.dataset.message.values[0])


def _always_fails(base, settings, index, seed):
    raise RuntimeError("injected")


def test_json_outputs_are_strict(tmp_path):
    """No run ok: the fractions are NaN in memory and null in summary.json (never the non-JSON token NaN)."""

    def strict(text: str):
        return json.loads(text, parse_constant=lambda token: pytest.fail(f"non-strict JSON token {token}"))

    res = mc.run_campaign(
        mc.CampaignSettings(runs=2, t_final=0.1, torque_limit=math.inf),
        tmp_path / "o",
        workers=1,
        progress=False,
        run_fn=_always_fails,
        figures=False,
    )
    assert math.isnan(res.summary["converged_fraction"])
    summary = strict((tmp_path / "o" / "summary.json").read_text())
    assert summary["converged_fraction"] is None and summary["ok"] == 0
    assert strict((tmp_path / "o" / "campaign.json").read_text())["torque_limit"] == "inf"


def test_a_stopped_pool_leaves_no_thread_running():
    """Was: stop_pool shut the pool down without waiting, so its manager thread (not a daemon) was still running
    when the interpreter exited after an interrupt, and its teardown raced with the exit hook (Python < 3.12 printed
    "OSError: [Errno 9] Bad file descriptor" after the one-line message).  Every thread the pool started has ended
    when stop_pool returns, the tasks still running included."""
    from fsmctl.parallel import stop_pool, worker_pool

    before = set(threading.enumerate())
    with worker_pool(2) as pool:
        futures = [pool.submit(time.sleep, 30) for _ in range(4)]
        time.sleep(0.5)  # the workers have started and are busy
        stop_pool(pool)
        left = [t for t in set(threading.enumerate()) - before if t.is_alive()]
    assert left == [], [t.name for t in left]
    assert all(f.done() for f in futures)
