"""``python3 -m solver docs``: the generated reference pages are current, and ``--check`` says when not.

Reference: the text the generator writes from ``solver.case.FIELDS`` and ``solver.study.results``
(read whole and compared as strings with the committed pages, not a substring test).
"""

from __future__ import annotations

import shutil

import pytest

from solver.case import FIELDS
from solver.cli import docs
from solver.study import motion
from solver.study.results import VARIABLES
from tests.conftest import ROOT, run_cli

DOCS = ROOT / "docs"
PAGES = (docs.CASE_PAGE, docs.RESULTS_PAGE)


@pytest.mark.serial
@pytest.mark.parametrize("name", PAGES)
def test_the_committed_page_is_what_the_command_writes(tmp_path, name):
    """Each committed page equals, whole, the file the command writes into an empty directory."""
    result = run_cli("docs", "--output", str(tmp_path))
    assert result.returncode == 0, result.stderr
    written = (tmp_path / name).read_text(encoding="utf-8")
    committed = (DOCS / name).read_text(encoding="utf-8")
    assert committed == written, f"docs/{name} is stale: run `python3 -m solver docs`"
    assert written == docs.render()[name]
    assert not [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]  # no temporary left


def test_every_field_and_variable_has_its_row():
    """One row per case key (with its unit, default and allowed range) and per results variable."""
    case_page, results_page = docs.case_reference(), docs.results_reference()
    for spec in FIELDS:
        rows = [line for line in case_page.splitlines() if line.startswith(f"| `{spec.name}` |")]
        assert len(rows) == 1, spec.name
        assert spec.allowed().replace("|", "\\|") in rows[0]
    assert "| `engine.rod_mass_kg` | kg | 0.55 | > 0 |" in case_page
    assert "| `gas.combustion_start_deg` | deg | 350 | (180, 540) |" in case_page
    results_nc, motion_nc = results_page.split("## `bearing --motion FILE`")  # (names may repeat)
    for name in VARIABLES:
        assert sum(line.startswith(f"| `{name}` |") for line in results_nc.splitlines()) == 1, name
    assert "| `h_min` | m | minimum film thickness |" in results_nc
    for name in (*motion.OUTPUTS, *motion.MOTION_VARIABLES):
        assert sum(line.startswith(f"| `{name}` |") for line in motion_nc.splitlines()) == 1, name


@pytest.mark.serial
def test_check_passes_on_the_committed_pages_and_fails_on_a_modified_copy(tmp_path):
    """--check: exit 0 on the committed pages; exit 1 with one line naming the stale file on a copy
    with one character changed, and on a copy with a page missing; the copy is left as it was."""
    assert run_cli("docs", "--check").returncode == 0
    copy = tmp_path / "docs"
    copy.mkdir()
    for name in PAGES:
        shutil.copy(DOCS / name, copy / name)
    assert run_cli("docs", "--check", "--output", str(copy)).returncode == 0

    page = copy / docs.RESULTS_PAGE
    modified = page.read_text(encoding="utf-8").replace("minimum film thickness", "minimum film thicknes")
    page.write_text(modified, encoding="utf-8")
    result = run_cli("docs", "--check", "--output", str(copy))
    assert result.returncode == 1
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and docs.RESULTS_PAGE in lines[0], result.stderr
    assert "Traceback" not in result.stderr
    assert page.read_text(encoding="utf-8") == modified  # --check writes nothing

    page.unlink()
    (copy / docs.CASE_PAGE).write_text("", encoding="utf-8")
    result = run_cli("docs", "--check", "--output", str(copy))
    assert result.returncode == 1 and docs.CASE_PAGE in result.stderr
