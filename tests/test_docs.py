"""The documentation: generated figures, no measurement history on product pages, a strict build."""

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
MARKER = re.compile(r"<!--\s*(figure|api):\s*([\w.\-]+)\s*-->")
# the phrases of a research log: kept in docs/research/ and CHANGELOG.md, never on a product page
CODE_HISTORY = r"measured again|on this (2-core )?machine|, now [0-9.]+ (mm|s|µT)"
MONTHS = "January|February|March|April|May|June|July|August|September|October|November|December"
HISTORY = re.compile(CODE_HISTORY + r"|\b20[0-9]{2}-[01][0-9]-[0-3][0-9]\b"
                     + rf"|\b({MONTHS}) 20[0-9]{{2}}\b" + r"|\bissue #?[0-9]+|\(#[0-9]+\)", re.I)

RESEARCH_LINK = re.compile(r"\(research/[^)]*\)")  # a dated note's name is no history


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def _product_pages() -> list[Path]:
    return [p for p in sorted(DOCS.rglob("*.md")) if "research" not in p.parts] + \
        [ROOT / "README.md"]


def test_every_marker_on_the_pages_renders():
    hooks = _load("docs_hooks")
    markers = [(p, m) for p in sorted(DOCS.rglob("*.md")) for m in MARKER.finditer(p.read_text())]
    assert {m.group(1) for _, m in markers} == {"figure", "api"}
    for page, match in markers:
        rendered = hooks._replace(match)
        assert "|" in rendered or "##" in rendered, f"{page}: {match.group(0)} rendered nothing"


def test_a_figure_table_says_which_command_wrote_it():
    figures = _load("docs_figures")
    for path in sorted((DOCS / "figures").glob("*.json")):
        snapshot = json.loads(path.read_text())
        assert snapshot["written_by"].startswith(("whiskercal bench", "whiskercal twin validate",
                                                  "whiskercal twin describe",
                                                  "python scripts/sessions.py"))
        assert f"`{snapshot['written_by']}`" in figures.render(path.stem)
    with pytest.raises(KeyError, match="unknown figure"):
        figures.render("no-such-figure")


def test_the_sensor_files_table_has_a_row_for_each_file_and_no_typed_figure():
    figures = _load("docs_figures")
    table = figures.render("twin-describe")
    ids = sorted(p.stem for p in (ROOT / "sensors").glob("*.toml"))
    snapshot = json.loads((DOCS / "figures" / "twin-describe.json").read_text())
    assert sorted(d["sensor_id"] for d in snapshot["result"]["sensors"]) == ids
    assert all(f"| {sensor_id} |" in table for sensor_id in ids)
    page = (DOCS / "twin.md").read_text()
    assert "<!-- figure: twin-describe -->" in page and "| twin-paper-75mm |" not in page


def test_the_contour_results_are_the_benchs_not_typed():
    page = (DOCS / "contour.md").read_text()
    assert "<!-- figure: contour-target -->" in page
    assert not re.search(r"^\| (cylinder|rounded square|octagon|[0-9]) \|", page, re.M)
    table = _load("docs_figures").render("contour-target")
    assert "| yz-table | octagon |" in table and "| z-lookup | cylinder |" in table


SNIPPET = re.compile(r'--8<-- "([^"]+)"')


def test_the_tutorials_outputs_are_the_demos_transcript():
    figures = _load("docs_figures")
    page = (DOCS / "walkthrough.md").read_text()
    included = SNIPPET.findall(page)
    assert included == [f"docs/figures/walkthrough/{n}.txt" for n in figures.TRANSCRIPT_NAMES]
    assert all((ROOT / path).read_text().strip() for path in included)


def test_product_pages_carry_no_measurement_history():
    found = [f"{p.relative_to(ROOT)}:{n}: {line.strip()[:80]}"
             for p in _product_pages() for n, line in enumerate(p.read_text().splitlines(), 1)
             if HISTORY.search(RESEARCH_LINK.sub("", line))]
    code = re.compile(CODE_HISTORY, re.I)
    found += [f"{p.relative_to(ROOT)}:{n}" for p in sorted((ROOT / "whiskercal").rglob("*.py"))
              for n, line in enumerate(p.read_text().splitlines(), 1) if code.search(line)]
    assert not found, "\n".join(found)


@pytest.mark.slow
def test_the_site_builds_strictly(tmp_path):
    site = tmp_path / "site"
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet",
                             "--site-dir", str(site)], cwd=ROOT, capture_output=True, text=True,
                            timeout=600, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert result.returncode == 0, result.stderr[-3000:]
    cli_page = (site / "cli" / "index.html").read_text()
    for command in ("whiskercal collect", "whiskercal fit", "whiskercal optimal-depth run"):
        assert f">{command}<" in cli_page
    assert "docs/figures/tip-extraction.json" in (site / "bench" / "index.html").read_text()
    assert "Tracker.update" in (site / "api" / "index.html").read_text()
