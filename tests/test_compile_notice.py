"""The one-line notice that the generated C is being compiled (issue 15): once on a first compile, never from the cache.

The compile cache is pointed at ``tmp_path`` (``FSMCTL_CACHE_DIR``), so the first :func:`compiled_library` of the
paper's law must run the compiler and log exactly one INFO record on the ``fsmctl`` logger tree naming the law;
loading the same library again from that (now filled) cache, with the in-process memo cleared, must log nothing.
One compile (~10 s) in all.
"""

from __future__ import annotations

import logging

import pytest

from fsmctl.model import generated_code


def _notices(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.name.startswith("fsmctl") and "compiling the generated C" in r.getMessage()]


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    """An empty compile cache under ``tmp_path``, a real compiler, and no memo of an earlier load."""
    monkeypatch.setenv("FSMCTL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("FSMCTL_NO_COMPILE", raising=False)
    monkeypatch.delenv("FSMCTL_PORTABLE", raising=False)
    if generated_code.c_compiler() is None:
        pytest.skip("no C compiler: nothing is ever compiled, so there is no notice to give")
    generated_code.compiled_library.cache_clear()
    yield tmp_path / "cache"
    generated_code.compiled_library.cache_clear()  # later tests load from their own cache again


def test_first_compile_logs_one_notice_and_the_cache_none(empty_cache, caplog):
    caplog.set_level(logging.INFO, logger="fsmctl")
    assert not empty_cache.exists() or not any(empty_cache.rglob("libfsmctl*"))

    first = generated_code.compiled_library()
    assert first is not None, "the compiler failed: no library to test the notice with"
    assert first.path.is_relative_to(empty_cache), "the library was not compiled in the empty cache"
    notices = _notices(caplog)
    assert len(notices) == 1, [r.getMessage() for r in notices]
    assert notices[0].levelno == logging.INFO
    assert notices[0].name == "fsmctl.model.generated_code"
    assert "'fsm'" in notices[0].getMessage()
    assert "10 s" in notices[0].getMessage()

    caplog.clear()
    generated_code.compiled_library.cache_clear()  # forget the in-process memo: the next load reads the disk cache
    second = generated_code.compiled_library()
    assert second is not None and second.path == first.path, "the second load did not come from the cache"
    assert _notices(caplog) == []


def test_the_notice_of_a_derived_law_says_what_it_is_and_which_script_it_is_from(empty_cache, caplog):
    """A law derived from a script is no name of `fsmctl laws`: its notice adds the law's declared doc and its script
    (a fresh user met "compiling the generated C for law 'fsm_unswitched'" from `fsmctl reproduce`, a name listed
    nowhere)."""
    from fsmctl.model.laws import resolve_law
    from fsmctl.studies.explain_laws import law_script

    code = resolve_law(str(law_script()))
    caplog.set_level(logging.INFO, logger="fsmctl")
    assert generated_code.compiled_library(code.folder) is not None
    (notice,) = (r.getMessage() for r in _notices(caplog))
    assert notice.startswith("compiling the generated C for law 'fsm_unswitched' (fast sliding mode"), notice
    assert "error MRP not switched to the shadow set; fsm_unswitched.py; first use, about 10 s)" in notice, notice


_FLY_PID = """
import sys, warnings
warnings.simplefilter("ignore")
import fsmctl
s = fsmctl.paper_scenario("1").replace(controller={"law": "pid"}, simulation={"t_final": 1.0})
r = fsmctl.simulate(s)
r.save(sys.argv[1])  # the result file: theta_e by the metrics' sample loops in C
print(r.raem_deg[-1] >= 0)  # the relative angles' C loop
paths = {line.split()[-1] for line in open("/proc/self/maps") if "libfsmctl" in line}
print(len(paths), sorted(paths))
"""


def test_flying_another_law_maps_no_library_of_the_paper_law(tmp_path):
    """A run of ``pid`` takes the model's functions and the metrics' C loops from pid's own library (every library holds
    them, compiled alike): the paper law's library is neither built nor loaded (a fresh user saw "compiling the
    generated C for law 'fsm'" for a study of their own law).  In a fresh process, which maps one library only."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    if not Path("/proc/self/maps").exists() or generated_code.c_compiler() is None:
        pytest.skip("needs Linux's /proc/self/maps and a C compiler")
    out = subprocess.run(
        [sys.executable, "-c", _FLY_PID, str(tmp_path / "pid.nc")],
        capture_output=True,
        text=True,
        env={k: v for k, v in os.environ.items() if k != "FSMCTL_NO_COMPILE"},
        check=True,
    )
    lines = out.stdout.strip().splitlines()
    assert lines[0] == "True" and lines[1].startswith("1 "), out.stdout
    assert "for law 'fsm'" not in out.stderr, out.stderr
