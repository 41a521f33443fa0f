"""Peak memory of a large formation run (``python benchmarks/memory.py [--quick] [--no-figures] [--old PATH]``).

The workload is what ``fsmctl simulate`` does with a run: 200 agents on a bidirectional ring (Case 1's
agents repeated, k^i = 8, Table 2's switching k^j), the paper's numerics (RK4, dt = 1 ms, outputs every
0.01 s) over 100 s, then ``summary()`` (AAEM eq 42, RAEM eq 43 over all 200 x 199 ordered pairs), the NetCDF
file and (unless ``--no-figures``) the four figures.  Each measurement runs in a fresh Python process and reads
its peak resident set size with ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` after each phase (the peak
so far, so the phases are cumulative); the workload runs in a fork of that fresh interpreter, because Linux
carries ``ru_maxrss`` across ``exec`` and a process started by a large parent would report the parent's peak.

The bar: 2 GB peak RSS for the 100 s run.  ``--old PATH`` also runs a shorter horizon on another checkout
of fsmctl (e.g. ``git worktree add /tmp/old <commit>``; put on ``PYTHONPATH``), and the same horizon on this
one, for a before/after comparison (the old code's relative-attitude metric held a samples x agents^2 array:
the 100 s run would need ~40 GB).

Writes ``benchmarks/memory_results.json`` (machine, date, versions, every measurement).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BAR_BYTES = 2 * 10**9
"""2 GB: the bar for the 100 s, 200-agent run."""


# ----------------------------------------------------------------------------- the child process


def _child(n: int, t_final: float, figures: bool, out_dir: str) -> dict:
    """Run the workload in this (fresh) process; peak RSS after each phase."""
    import dataclasses
    import resource
    import time
    import warnings

    def peak() -> int:  # bytes (Linux reports kB)
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    phases = {"import": peak()}
    times = {}
    warnings.filterwarnings("ignore", message=".*triangle inequality.*")
    import fsmctl
    from fsmctl.model.topology import ring
    from fsmctl.simulation.simulator import simulate

    base = fsmctl.paper_scenario("1")
    agents = tuple(base.agents[i % base.n_agents] for i in range(n))
    scenario = dataclasses.replace(base, agents=agents, topology=ring(n, 8.0, base.topology.links[0].k_j)).replace(
        simulation={"t_final": t_final, "output_interval": 0.01, "dt": 1e-3}
    )
    simulate(scenario.replace(simulation={"t_final": 0.01}), progress=False)  # compile/load outside the phases
    phases["setup"] = peak()
    t0 = time.perf_counter()
    result = simulate(scenario, progress=False)
    times["simulate_s"] = time.perf_counter() - t0
    times["c_loop_s"] = result.wall_time
    phases["simulate"] = peak()
    t0 = time.perf_counter()
    summary = result.summary()
    times["summary_s"] = time.perf_counter() - t0
    phases["summary"] = peak()
    t0 = time.perf_counter()
    result.save(Path(out_dir) / "run.nc")
    times["netcdf_s"] = time.perf_counter() - t0
    phases["netcdf"] = peak()
    if figures:
        from fsmctl.studies.figures import save_figure, simulation_figures

        t0 = time.perf_counter()
        for name, fig in simulation_figures(result).items():
            save_figure(fig, Path(out_dir) / name)
        times["figures_s"] = time.perf_counter() - t0
        phases["figures"] = peak()
    return {
        "n_agents": n,
        "t_final_s": t_final,
        "output_samples": int(result.time.size),
        "fsmctl": str(Path(fsmctl.__file__).resolve().parent),
        "peak_rss_bytes": phases,
        "times": times,
        "raem_steady_max_deg": summary["raem_steady_max_deg"],
        "output_buffers_bytes": int(sum(getattr(result, k).nbytes for k in ("sigma", "omega", "sigma_e", "omega_e", "s", "u", "u_unsaturated"))),
    }  # fmt: skip


def _run_child(n: int, t_final: float, figures: bool, out_dir: str) -> int:
    """Run :func:`_child` in a process forked from this small one and print its JSON report.

    Linux carries ``ru_maxrss`` across ``exec`` (the old image's high-water mark, and ``subprocess`` execs
    from a vfork of the parent): a process started by a large parent (the benchmark driver, pytest) reports
    at least the parent's peak.  A process *forked* starts from its parent's current size, so the workload
    runs in a fork of this freshly started interpreter, which has imported nothing heavy.
    """
    if not hasattr(os, "fork"):  # pragma: no cover - not POSIX: measure in place
        print(json.dumps(_child(n, t_final, figures, out_dir)))
        return 0
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the measured process
        os.close(read_fd)
        code = 0
        try:
            payload = _child(n, t_final, figures, out_dir)
        except BaseException as exc:  # reported to the parent, which exits nonzero
            import traceback

            traceback.print_exc()
            payload, code = {"error": f"{type(exc).__name__}: {exc}"}, 1
        with os.fdopen(write_fd, "w") as fh:
            fh.write(json.dumps(payload))
        sys.stderr.flush()
        os._exit(code)
    os.close(write_fd)
    with os.fdopen(read_fd) as fh:
        payload = fh.read()
    _, status = os.waitpid(pid, 0)
    code = os.waitstatus_to_exitcode(status)
    if code == 0:
        print(payload)
    else:
        print(f"measured process failed ({code}): {payload}", file=sys.stderr)
    return code


def measure(n: int, t_final: float, *, figures: bool = True, pythonpath: str | None = None) -> dict:
    """Run the workload in a fresh interpreter (optionally with another fsmctl first on the path)."""
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    if pythonpath:
        env["PYTHONPATH"] = pythonpath + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(n), str(t_final), tmp]
        if not figures:
            cmd.append("--no-figures")
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp)
    if proc.returncode != 0:
        return {"n_agents": n, "t_final_s": t_final, "error": (proc.stderr.strip().splitlines() or ["?"])[-1],
                "returncode": proc.returncode}  # fmt: skip
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _versions() -> dict:
    import casadi
    import matplotlib
    import numpy
    import scipy
    import xarray

    import fsmctl

    return {
        "python": platform.python_version(),
        "fsmctl": fsmctl.__version__,
        "numpy": numpy.__version__,
        "casadi": casadi.__version__,
        "scipy": scipy.__version__,
        "xarray": xarray.__version__,
        "matplotlib": matplotlib.__version__,
    }


def _machine() -> dict:
    info = {"platform": platform.platform(), "processor": platform.processor(), "cpus": os.cpu_count()}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                info["cpu"] = line.split(":", 1)[1].strip()
                break
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                info["memory_total_bytes"] = int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True)
        info["git_head"] = rev.stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain"], cwd=ROOT, capture_output=True, text=True)
        info["git_dirty"] = bool(dirty.stdout.strip())
    except (OSError, subprocess.CalledProcessError):
        pass
    return info


def _gb(x: int) -> str:
    return f"{x / 1e9:.2f} GB"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="10 s instead of 100 s")
    ap.add_argument("--agents", type=int, default=200)
    ap.add_argument("--no-figures", dest="figures", action="store_false", help="skip the four figures")
    ap.add_argument("--old", metavar="PATH", help="another fsmctl checkout to compare with (on PYTHONPATH)")
    ap.add_argument("--old-t-final", type=float, nargs="+", default=[5.0, 10.0], metavar="S")
    ap.add_argument("--out", type=Path, default=HERE / "memory_results.json")
    ap.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        return _run_child(int(args.child[0]), float(args.child[1]), args.figures, args.child[2])
    t_final = 10.0 if args.quick else 100.0
    report = {
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "machine": _machine(),
        "versions": _versions(),
        "workload": f"{args.agents} agents on a ring (Case 1 agents repeated, k^i = 8, Table 2 k^j), RK4 dt = 1 ms, "
        "outputs every 0.01 s; simulate + summary() + NetCDF" + (" + figures" if args.figures else ""),
        "bar_bytes": BAR_BYTES,
    }
    print(f"measuring {args.agents} agents over {t_final:g} s ...", flush=True)
    main_run = measure(args.agents, t_final, figures=args.figures)
    report["run"] = main_run
    if "error" in main_run:
        print(f"  failed: {main_run['error']}")
        ok = False
    else:
        peak = max(main_run["peak_rss_bytes"].values())
        ok = peak <= BAR_BYTES
        report["peak_rss_bytes"] = peak
        report["within_bar"] = ok
        print(f"  peak RSS {_gb(peak)} (bar {_gb(BAR_BYTES)}): {'ok' if ok else 'OVER'}; phases "
              + ", ".join(f"{k} {_gb(v)}" for k, v in main_run["peak_rss_bytes"].items()))  # fmt: skip
    if args.old:
        report["comparison"] = []
        for t in args.old_t_final:
            for label, path in (("old", args.old), ("new", None)):
                print(f"comparison: {label} code, {args.agents} agents over {t:g} s ...", flush=True)
                r = measure(args.agents, t, figures=args.figures, pythonpath=path)
                r["code"] = label if path is None else f"{label} ({path})"
                report["comparison"].append(r)
                if "error" not in r:
                    print(f"  peak RSS {_gb(max(r['peak_rss_bytes'].values()))}")
                else:
                    print(f"  failed: {r['error']}")
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
