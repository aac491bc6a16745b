"""Every input file is checked like the case keys: a binary or non-UTF-8 file (case, pressure trace,
speed trace, sweep file) gives one line ``error: ...`` naming the file, exit status 2, no traceback,
and nothing written.

The commands run in a subprocess (the real entry point); ``engine`` and ``batch --list`` read the
files without dolfinx, so each test takes a second or two.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import assert_one_line_error

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.serial

#: bytes that are not UTF-8 (0xff never occurs in UTF-8; 0xc3 0x28 is a broken two-byte sequence)
GARBAGE = bytes(range(256)) * 4 + b"\xff\xfe\xc3\x28"
LATIN1 = "crank_angle_deg,pressure_bar\n0,1.0\n# Zylinderdruck gemessen (M\u00fcller)\n720,1.0\n".encode(
    "latin-1"
)


def solver(*arguments: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "LC_ALL": "C"}  # a C locale must not change the reading
    env.pop("OMPI_COMM_WORLD_SIZE", None)
    return subprocess.run(
        [sys.executable, "-m", "solver", *arguments],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )


def listing(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


def test_binary_case_file(tmp_path):
    case = tmp_path / "case"
    case.mkdir()
    (case / "case.toml").write_bytes(GARBAGE)
    before = listing(tmp_path)
    result = solver("engine", str(case), "--output", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(result, "case file", "case.toml", "not a UTF-8 text file")
    assert listing(tmp_path) == before


def test_case_file_with_nul_bytes(tmp_path):
    (tmp_path / "case.toml").write_bytes(b"[engine]\x00\x00\nspeed_rpm = 2000\n")
    result = solver("engine", str(tmp_path / "case.toml"), "--output", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(result, "case file", "NUL")


@pytest.mark.parametrize("content", [GARBAGE, LATIN1], ids=["binary", "latin-1"])
def test_pressure_trace_that_is_not_utf8(tmp_path, content):
    (tmp_path / "case.toml").write_text('[gas]\npressure_file = "p.csv"\n')
    (tmp_path / "p.csv").write_bytes(content)
    result = solver("engine", str(tmp_path), "--output", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(result, "gas.pressure_file", "p.csv", "not a UTF-8 text file")
    assert not (tmp_path / "out").exists()


def test_speed_trace_that_is_not_utf8(tmp_path):
    (tmp_path / "case.toml").write_text('[engine]\nspeed_file = "n.csv"\n')
    (tmp_path / "n.csv").write_bytes(GARBAGE)
    result = solver("engine", str(tmp_path), "--output", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(result, "engine.speed_file", "n.csv", "not a UTF-8 text file")


def test_utf8_trace_with_a_byte_order_mark_is_read(tmp_path):
    """The reverse: a UTF-8 file (with a BOM and non-ASCII comments) is accepted under a C locale."""
    (tmp_path / "case.toml").write_text(
        '# Zylinderdruck \u00fcber dem Kurbelwinkel\n[gas]\npressure_file = "p.csv"\n', encoding="utf-8"
    )
    rows = "".join(f"{a},{1.0 + 50.0 * (a == 360)}\n" for a in range(0, 721, 10))
    (tmp_path / "p.csv").write_bytes(
        "\ufeffcrank_angle_deg,pressure_bar\n# gemessen \u00b0\n".encode() + rows.encode()
    )
    result = solver("engine", str(tmp_path), "--output", str(tmp_path / "out"), "--json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr


def test_binary_sweep_file(tmp_path):
    sweep = tmp_path / "study.toml"
    sweep.write_bytes(b'[sweep]\nbase = "x"\n' + GARBAGE)
    before = listing(tmp_path)
    result = solver("batch", str(sweep), "--list", cwd=tmp_path)
    assert_one_line_error(result, "study.toml")
    assert listing(tmp_path) == before
