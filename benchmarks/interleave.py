"""Issue 31's interleaving lever, measured: kernels printed for several lane groups per call vs one group per call.

Published CPU ensemble solvers interleave several independent SIMD groups in one function body so that the core
overlaps their dependency chains.  fsmctl's printer can do the same (:func:`fsmctl.codegen.batched.batched_source`
with ``groups=K``: each instruction printed once per group, side by side).  This section prints the Case 1
right-hand side's kernels for K = 2 and 3 groups from the CasADi graphs the library's kernels are printed from
(``generated/**/casadi``), compiles them with the library's flags beside the library's own kernels (K = 1), and
flies each on 48 agents' worth of lane groups (every lane active, each group its own inputs on pow's fast path),
alternated, min of the repeats, at 4 and 8 lanes.  The outputs of every K are compared bit for bit with the
library's kernel.  Used by ``benchmarks/run.py`` (section ``interleave``).
"""

from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path

GROUPS = (2, 3)
"""The interleavings measured against the library's kernels (one lane group per call)."""

AGENTS = 48
"""Agents per sweep of a kernel: a whole number of K-group calls for K = 1, 2, 3 at 4 and at 8 lanes (8 Case 1 runs,
the default Monte Carlo chunk)."""

_HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "batched.h"
#include "law_batched.h"
{includes}
#define AGENTS {agents}
static double now(void) {{ struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }}
typedef int (*kernel1)(const double *const *, double *const *, int);
typedef int (*kernelK)(const double *const *const *, double *const *const *, int);
typedef struct {{ const char *name; kernel1 one; kernelK k[{n_groups}]; int n_in, n_out; int nnz_in[64], nnz_out[64]; }} spec;
static const spec SPECS[] = {{
{specs}
}};
static const int GROUPS[] = {{{groups}}};
int main(int argc, char **argv) {{
  const long reps = atol(argv[1]);
  const int G = AGENTS / FSM_LANES;
  for (size_t s = 0; s < sizeof SPECS / sizeof SPECS[0]; ++s) {{
    const spec *S = &SPECS[s];
    int n_in = 0, n_out = 0;
    for (int i = 0; i < S->n_in; ++i) n_in += S->nnz_in[i];
    for (int i = 0; i < S->n_out; ++i) n_out += S->nnz_out[i];
    const double **arg = malloc(sizeof(double *) * G * S->n_in);
    double **res = malloc(sizeof(double *) * G * S->n_out * ({n_groups} + 1));
    double *in = malloc(sizeof(double) * G * n_in * FSM_LANES + 64);
    double *out = calloc((size_t)G * n_out * FSM_LANES * ({n_groups} + 1) + 8, sizeof(double));
    for (long k = 0; k < (long)G * n_in * FSM_LANES; ++k) in[k] = 0.05 + 0.001 * ((7 * k + s) % 13); /* pow's fast path */
    for (int g = 0; g < G; ++g) {{
      double *p = in + (size_t)g * n_in * FSM_LANES;
      for (int i = 0; i < S->n_in; ++i) arg[g * S->n_in + i] = p, p += S->nnz_in[i] * FSM_LANES;
      for (int v = 0; v <= {n_groups}; ++v) {{
        double *q = out + ((size_t)v * G + g) * n_out * FSM_LANES;
        for (int i = 0; i < S->n_out; ++i) res[(v * G + g) * S->n_out + i] = q, q += S->nnz_out[i] * FSM_LANES;
      }}
    }}
    const double *const *A[AGENTS];
    double *const *R[({n_groups} + 1) * AGENTS];
    for (int g = 0; g < G; ++g) A[g] = arg + g * S->n_in;
    for (int v = 0; v <= {n_groups}; ++v)
      for (int g = 0; g < G; ++g) R[v * G + g] = res + (v * G + g) * S->n_out;
    double best[{n_groups} + 1];
    for (int v = 0; v <= {n_groups}; ++v) best[v] = 1e30;
    for (int r = 0; r < 5; ++r)
      for (int v = 0; v <= {n_groups}; ++v) {{ /* alternated: K = 1, then each interleaving */
        const double t = now();
        for (long n = 0; n < reps; ++n) {{
          if (v == 0)
            for (int g = 0; g < G; ++g) S->one(A[g], R[g], FSM_LANES);
          else
            for (int g = 0; g < G; g += GROUPS[v - 1]) S->k[v - 1](A + g, R + v * G + g, FSM_LANES);
          __asm__ volatile("" ::: "memory");
        }}
        const double dt = now() - t;
        best[v] = dt < best[v] ? dt : best[v];
      }}
    printf("%s", S->name);
    for (int v = 0; v <= {n_groups}; ++v) {{
      const int same = memcmp(out, out + (size_t)v * G * n_out * FSM_LANES, sizeof(double) * G * n_out * FSM_LANES) == 0;
      printf(" %.6e %d", best[v] / reps / AGENTS, same); /* seconds per agent; bits equal to K = 1 */
    }}
    printf("\n");
    free(arg), free(res), free(in), free(out);
  }}
  return 0;
}}
"""


def _casadi_functions(names) -> list:
    """The CasADi graphs the library's kernels of ``names`` are printed from (the model's, else the paper law's)."""
    from fsmctl.model.generated_code import law_sx_function, manifest, model_sx_function
    from fsmctl.model.laws import builtin_laws

    model = {f["name"] for f in manifest()["functions"]}
    law = builtin_laws()["fsm"].folder
    return [(n, model_sx_function(n) if n in model else law_sx_function(law, n)) for n in names]


def _spec(name: str, function) -> str:
    from fsmctl.codegen.batched import kernel_name

    k = kernel_name(name)
    nnz_in = ", ".join(str(function.nnz_in(i)) for i in range(function.n_in()))
    nnz_out = ", ".join(str(function.nnz_out(i)) for i in range(function.n_out()))
    interleaved = ", ".join(f"{k}_x{g}" for g in GROUPS)
    return (f'  {{"{name}", {k}, {{{interleaved}}}, {function.n_in()}, {function.n_out()}, {{{nnz_in}}}, '
            f"{{{nnz_out}}}}},")  # fmt: skip


def _stack_operands(exe: Path, name: str) -> dict | None:
    """Instructions with a stack operand (spilled values) in each K's compiled kernel, per lane group; None without
    objdump."""
    import re
    import shutil

    from fsmctl.codegen.batched import kernel_name

    objdump = shutil.which("objdump")
    if objdump is None:
        return None
    out = {}
    for g in (1, *GROUPS):
        symbol = kernel_name(name) + ("" if g == 1 else f"_x{g}")
        text = subprocess.run([objdump, "-d", "--no-show-raw-insn", f"--disassemble={symbol}", str(exe)],
                              capture_output=True, text=True, timeout=120, check=True).stdout  # fmt: skip
        out[str(g)] = len(re.findall(r"\((?:%rsp|%rbp)\)", text)) / g
    return out


def interleave_section(quick: bool, log, kernels) -> dict:
    """Nanoseconds per agent of each kernel in ``kernels`` with K = 1 (the library's), 2 and 3 lane groups per call,
    at 4 and 8 lanes, and whether every K gives the library's bits."""
    from fsmctl.codegen.batched import batched_header, batched_source
    from fsmctl.model.generated_code import (
        c_compiler,
        compile_flags,
        driver_source_dir,
        generated_dir,
        math_include_args,
    )
    from fsmctl.model.laws import builtin_laws

    cc = c_compiler()
    if cc is None:
        return {"skipped": "no C compiler"}
    functions = _casadi_functions(kernels)
    law_c, gen_c, csrc = builtin_laws()["fsm"].folder / "c", generated_dir() / "c", driver_source_dir()
    flags = [f for f in compile_flags(cc)[0] if f not in ("-shared", "-fPIC") and not f.startswith("-DFSM_LANES")]
    reps = 2_000 if quick else 20_000
    out: dict = {"agents": AGENTS, "groups": [1, *GROUPS], "widths": {}}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        sources = [gen_c / "batched.c", law_c / "law_batched.c", csrc / "fsm_pow.c", csrc / "fsm_trig.c"]
        includes = []
        for g in GROUPS:
            header = f"interleaved{g}.h"
            (tmp / header).write_text(batched_header([n for n, _ in functions], guard=f"INTERLEAVED{g}_H",
                                                     generator="benchmarks/interleave.py", groups=g))  # fmt: skip
            (tmp / f"interleaved{g}.c").write_text(batched_source(functions, header, generator="benchmarks/interleave.py",
                                                                   groups=g))  # fmt: skip
            sources.append(tmp / f"interleaved{g}.c")
            includes.append(f'#include "{header}"')
        (tmp / "harness.c").write_text(_HARNESS.format(
            includes="\n".join(includes), agents=AGENTS, n_groups=len(GROUPS), groups=", ".join(map(str, GROUPS)),
            specs="\n".join(_spec(n, f) for n, f in functions)))  # fmt: skip
        for width in (4, 8):
            exe = tmp / f"harness{width}"
            build = subprocess.run([cc, *flags, "-D_POSIX_C_SOURCE=199309L", f"-DFSM_LANES={width}", f"-I{gen_c}",
                                    f"-I{law_c}", f"-I{csrc}", f"-I{tmp}", *math_include_args(), str(tmp / "harness.c"),
                                    *map(str, sources), "-o", str(exe), "-lm"], capture_output=True, text=True)  # fmt: skip
            if build.returncode != 0:
                raise RuntimeError(f"interleave: the harness did not compile: {build.stderr[-2000:]}")
            got = subprocess.run([str(exe), str(reps // width)], capture_output=True, text=True, check=True,
                                 timeout=1800).stdout  # fmt: skip
            rows = {}
            for line in got.splitlines():
                name, *fields = line.split()
                ns = [1e9 * float(x) for x in fields[0::2]]
                rows[name] = {"ns_per_agent": dict(zip(map(str, out["groups"]), ns, strict=True)),
                              "same_bits": all(x == "1" for x in fields[1::2]),
                              "stack_per_group": _stack_operands(exe, name)}  # fmt: skip
            out["widths"][str(width)] = rows
            log(f"interleave {width} lanes: " + "; ".join(
                f"{n} " + "/".join(f"{v:.1f}" for v in r["ns_per_agent"].values()) + " ns" for n, r in rows.items()))  # fmt: skip
    return out


def markdown(res: dict | None) -> list[str]:
    """The section of ``results.md``."""
    if not res or "widths" not in res:
        return [] if not res else ["", "## Interleaved lane groups (issue 31)", "", f"Skipped: {res.get('skipped')}."]
    groups = res["groups"]
    head = " | ".join(f"{w} lanes, K = {g}" for w in res["widths"] for g in groups)
    lines = ["", "## Interleaved lane groups (issue 31)", "",
             "Each kernel of a Case 1 right-hand side printed for K lane groups per call (`fsmctl.codegen.batched."
             "batched_source(..., groups=K)`: every instruction once per group, side by side) beside the library's "
             f"kernel (K = 1), compiled with the library's flags; each swept over {res['agents']} agents (every lane "
             "active), alternated, min of 5; ns per agent (`benchmarks/interleave.py`).", "",
             f"| kernel | {head} | same bits |", "|---|" + "---|" * (len(groups) * len(res["widths"]) + 1)]  # fmt: skip
    names = list(next(iter(res["widths"].values())))
    for n in names:
        cells = [f"{res['widths'][w][n]['ns_per_agent'][str(g)]:.2f}" for w in res["widths"] for g in groups]
        same = all(res["widths"][w][n]["same_bits"] for w in res["widths"])
        lines.append(f"| {n} | {' | '.join(cells)} | {'yes' if same else 'NO'} |")
    total = {w: {g: sum(r["ns_per_agent"][str(g)] for r in rows.values()) for g in groups}
             for w, rows in res["widths"].items()}  # fmt: skip
    ratios = {w: {g: t[g] / t[groups[0]] for g in groups[1:]} for w, t in total.items()}
    one = min((t[groups[0]], w) for w, t in total.items())  # the fastest one-group kernels: what the engine can fly
    best = min((t[g] / one[0], w, g) for w, t in total.items() for g in groups[1:])
    within = min((v, w, g) for w, d in ratios.items() for g, v in d.items())
    spills = {w: {g: sum((r["stack_per_group"] or {}).get(str(g), 0) for r in rows.values()) for g in groups}
              for w, rows in res["widths"].items()}  # fmt: skip
    lines += ["", "The four kernels together, K groups per call / one group per call at the same width: " + "; ".join(
        f"{w} lanes " + ", ".join(f"K = {g}: {v:.2f}" for g, v in d.items()) for w, d in ratios.items()) + ". "
        f"Against the fastest one-group kernels ({one[1]} lanes), the fastest interleaved ones ({best[1]} lanes, "
        f"K = {best[2]}) take {best[0]:.2f}x the time. "]  # fmt: skip
    if best[0] >= 0.98:
        lines[-1] += (
            "Interleaving is no faster on this core"
            + (f" (within {within[1]} lanes K = {within[2]} took {within[0]:.2f} of K = 1, still slower than one group "
               f"at {one[1]} lanes)" if within[0] < 0.98 and within[1] != one[1] else "")
            + ", consistent with the core's out-of-order window overlapping one call's chains with the next call's "
            "already (not measured apart); and K groups per call keep K times the values alive: instructions with a "
            "stack operand (spilled values) per lane group, the four kernels together, "
            + "; ".join(f"{w} lanes " + ", ".join(f"K = {g}: {v:.0f}" for g, v in d.items()) for w, d in spills.items())
            + ". The engine keeps one lane group per call."
        )  # fmt: skip
    else:
        lines[-1] += "Interleaving pays on this core: a candidate for the engine's kernels."
    return lines
