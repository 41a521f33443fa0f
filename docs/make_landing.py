"""Write the site's committed result files from a full reproduction and an executed build.

The landing page (``docs/index.md``) and the findings page (``docs/findings.md``) show the result of the paper's
reproduction; the gallery (``docs/gallery/index.md``) shows a thumbnail per notebook.  Those are files committed
under ``docs/``, written by this script, never by hand::

    fsmctl reproduce --out reproduction                      # the full horizon (not --fast), ~3 minutes
    python docs/make_landing.py --reproduction reproduction

    sphinx-build -b html -d docs/_build/doctrees docs docs/_build/html   # executes the notebooks
    python docs/make_landing.py --executed docs/_build/jupyter_execute

``--reproduction DIR`` copies ``DIR/figures/fig01_aaem_case1.png`` to ``docs/_static/landing/`` and writes
``docs/_includes/verdicts-summary.md`` (one line: the claims and how many got each verdict) and
``docs/_includes/verdicts-table.md`` (one short row per claim) from ``DIR/claims.json``; a fast reproduction
(``--fast``: 10 s horizons) is refused, since its verdicts are not the findings.  ``--executed DIR`` writes
``docs/_static/gallery/<notebook>.png``, the first figure of each executed notebook ``DIR/**/<notebook>.ipynb``,
scaled to a thumbnail (a notebook without figures gets a card with its title).
"""

from __future__ import annotations

import argparse
import base64
import io
import json
import shutil
import sys
from collections import Counter
from pathlib import Path

DOCS = Path(__file__).resolve().parent
LANDING_FIGURE = "fig01_aaem_case1.png"
THUMBNAIL_WIDTH = 480


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def verdict_files(claims: dict) -> dict[str, str]:
    """``{file name: MyST text}`` of the verdict summary and table, from a ``claims.json`` of ``fsmctl reproduce``.

    Raises ``ValueError`` for a fast reproduction or one without claims.
    """
    if claims.get("fast"):
        raise ValueError("a fast reproduction (10 s horizons): its verdicts are not the findings; run it in full")
    rows = claims.get("claims") or []
    if not rows:
        raise ValueError("claims.json lists no claims")
    kinds = list(claims.get("verdict_kinds") or [])
    counts = Counter(c["verdict"] for c in rows)
    kinds += sorted(set(counts) - set(kinds))
    summary = (
        f"**{len(rows)} claims** of Section 4 checked against the paper's stated parameters: "
        + ", ".join(f"*{k}* **{counts.get(k, 0)}**" for k in kinds)
        + ".\n"
    )
    table = [
        "| claim | figures | the paper says | verdict |",
        "|---|---|---|---|",
        *(
            f"| **{_cell(c['id'])}**: {_cell(c['claim'])} | {_cell(c['figures'])} | {_cell(c['paper_value'])} "
            f"| **{_cell(c['verdict'])}** |"
            for c in rows
        ),
    ]
    source = "<!-- Written by docs/make_landing.py from claims.json of a full `fsmctl reproduce`; do not edit. -->\n"
    return {"verdicts-summary.md": source + summary, "verdicts-table.md": source + "\n".join(table) + "\n"}


def write_reproduction(reproduction: Path, docs: Path = DOCS) -> list[Path]:
    """Write the landing figure and the verdict includes from a full ``fsmctl reproduce`` folder; return them."""
    claims = json.loads((reproduction / "claims.json").read_text(encoding="utf-8"))
    written = []
    includes = docs / "_includes"
    includes.mkdir(exist_ok=True)
    for name, text in verdict_files(claims).items():
        (includes / name).write_text(text, encoding="utf-8")
        written.append(includes / name)
    landing = docs / "_static" / "landing"
    landing.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(reproduction / "figures" / LANDING_FIGURE, landing / LANDING_FIGURE)
    written.append(landing / LANDING_FIGURE)
    return written


def first_figure(notebook: dict) -> bytes | None:
    """The PNG bytes of the first image output of a notebook (nbformat 4 JSON), or None."""
    for cell in notebook.get("cells", []):
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            if "image/png" in data:
                png = data["image/png"]
                return base64.b64decode("".join(png) if isinstance(png, list) else png)
    return None


def title_card(notebook: dict, width: int = THUMBNAIL_WIDTH) -> bytes:
    """A thumbnail for a notebook without figures: its title (first Markdown heading) on a plain card, as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    title = "notebook"
    for cell in notebook.get("cells", []):
        if cell.get("cell_type") == "markdown":
            source = "".join(cell.get("source", []))
            heading = next((line[2:] for line in source.splitlines() if line.startswith("# ")), None)
            if heading:
                title = heading
                break
    number, _, rest = title.partition(" — ")
    fig = plt.figure(figsize=(width / 100, width / 160), dpi=100)
    fig.text(0.5, 0.62, number if rest else "", ha="center", va="center", fontsize=36, color="#1f4e79")
    fig.text(0.5, 0.3, rest or title, ha="center", va="center", fontsize=14, wrap=True)
    out = io.BytesIO()
    fig.savefig(out, format="png", facecolor="#eef3f8")
    plt.close(fig)
    return out.getvalue()


def thumbnail(png: bytes, width: int = THUMBNAIL_WIDTH) -> bytes:
    """``png`` scaled to ``width`` pixels wide (not enlarged), as PNG."""
    from PIL import Image

    image = Image.open(io.BytesIO(png))
    if image.width > width:
        image = image.resize((width, round(image.height * width / image.width)), Image.LANCZOS)
    out = io.BytesIO()
    image.save(out, format="PNG", optimize=True)
    return out.getvalue()


def write_thumbnails(executed: Path, notebooks: list[str], docs: Path = DOCS) -> list[Path]:
    """Write ``docs/_static/gallery/<name>.png`` for each notebook name found executed under ``executed``."""
    out = docs / "_static" / "gallery"
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in notebooks:
        found = sorted(executed.rglob(f"{name}.ipynb"))
        if not found:
            raise FileNotFoundError(f"{executed}: no executed {name}.ipynb (build the site with the notebooks run)")
        notebook = json.loads(found[0].read_text(encoding="utf-8"))
        png = first_figure(notebook)
        (out / f"{name}.png").write_bytes(thumbnail(png) if png is not None else title_card(notebook))
        written.append(out / f"{name}.png")
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python docs/make_landing.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--reproduction", type=Path, help="a full `fsmctl reproduce` output folder")
    parser.add_argument("--executed", type=Path, help="the executed notebooks of a site build (jupyter_execute)")
    args = parser.parse_args(argv)
    if args.reproduction is None and args.executed is None:
        parser.error("give --reproduction, --executed or both")
    written = []
    try:
        if args.reproduction is not None:
            written += write_reproduction(args.reproduction)
        if args.executed is not None:
            names = sorted(p.stem for p in (DOCS.parent / "notebooks").glob("*.py"))
            written += write_thumbnails(args.executed, names)
    except (OSError, ValueError) as exc:
        print(f"make_landing: {exc}", file=sys.stderr)
        return 2
    for path in written:
        print(f"wrote {path.relative_to(DOCS.parent)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
