"""A small end no engine has is refused as a likely unit slip (solver.film_rules.check_geometry, called by
the case loader and by the bearing and stribeck commands), and the case says which sections it defaulted.

The allowed ranges in the messages are recomputed here by hand from the rules (R in [1e-4, 1] m, c/R in
[1e-4, 1e-2], B/R in [0.05, 5], c > sqrt(sigma_1^2 + sigma_2^2), an elastic bushing <= R) and the
default pin radius of 10 mm; the boundaries are accepted (closed ranges, to rounding).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from solver.case import SECTIONS, defaults_note, load_case
from solver.errors import InputError
from solver.film_rules import FLAG_LENGTHS, check_geometry

ROOT = Path(__file__).resolve().parents[1]


def _case(tmp_path: Path, text: str):
    (tmp_path / "case.toml").write_text(text)
    return load_case(tmp_path)


@pytest.mark.serial
@pytest.mark.parametrize(
    "text, message",
    [
        # the case: a clearance in mm given as um; c/R = 1.2e-6; R = 10 mm -> c in [1, 100] um
        (
            "[small_end]\nclearance_um = 0.012\n",
            "small_end.clearance_um = 0.012 is out of range (allowed: [1, 100] um, clearance / radius in "
            "[0.0001, 0.01]; if you meant 0.012 mm: small_end.clearance_um = 12)",
        ),
        # a clearance in m: 1e-5 um is below 1 um, no unit makes 1e-5 plausible but m (10 um)
        (
            "[small_end]\nclearance_um = 1e-5\n",
            "small_end.clearance_um = 1e-05 is out of range (allowed: [1, 100] um, clearance / radius in "
            "[0.0001, 0.01]; if you meant 1e-05 m: small_end.clearance_um = 10)",
        ),
        # a pin radius in m: 0.01 mm < 0.1 mm (1e-4 m)
        (
            "[small_end]\npin_radius_mm = 0.01\n",
            "small_end.pin_radius_mm = 0.01 is out of range (allowed: [0.1, 1000] mm; if you meant 0.01 m: "
            "small_end.pin_radius_mm = 10)",
        ),
        # a width in m: B/R in [0.05, 5] with R = 10 mm -> B in [0.5, 50] mm
        (
            "[small_end]\nwidth_mm = 0.02\n",
            "small_end.width_mm = 0.02 is out of range (allowed: [0.5, 50] mm, width / radius in [0.05, 5]; "
            "if you meant 0.02 m: small_end.width_mm = 20)",
        ),
        # c/R = 1.5e-4 is plausible, but sigma = sqrt(0.1^2 + 2^2) = 2.0025 um is above c = 1.5 um
        (
            "[small_end]\nclearance_um = 1.5\n[surface]\nsigma_bushing_um = 2\n",
            "small_end.clearance_um = 1.5 is below the composite roughness sqrt(surface.sigma_pin_um^2 + "
            "surface.sigma_bushing_um^2) = 2.0025 (allowed: clearance > composite roughness)",
        ),
        # an elastic bushing 15 mm thick on a 10 mm pin
        (
            '[small_end]\nelastic = "winkler"\nbushing_thickness_mm = 15\n',
            "small_end.bushing_thickness_mm = 15 is out of range (allowed: [0, 10] mm, at most the radius)",
        ),
    ],
    ids=["clearance-in-mm", "clearance-in-m", "radius-in-m", "width-in-m", "below-roughness", "bushing"],
)
def test_an_implausible_small_end_is_one_line_naming_the_unit_slip(tmp_path, text, message):
    with pytest.raises(InputError) as err:
        _case(tmp_path, text)
    assert str(err.value) == message


@pytest.mark.serial
@pytest.mark.parametrize(
    "text",
    [
        "[small_end]\nclearance_um = 1\n",  # c/R = 1e-4 exactly (and above sigma = 0.316 um)
        "[small_end]\nclearance_um = 100\n",  # c/R = 1e-2 exactly
        "[small_end]\nwidth_mm = 0.5\n",  # B/R = 0.05 exactly
        "[small_end]\nwidth_mm = 50\n",  # B/R = 5 exactly
        "[small_end]\npin_radius_mm = 1000\nwidth_mm = 1000\nclearance_um = 1000\n",  # R = 1 m
        "[small_end]\nclearance_um = 1.5\n[surface]\nsigma_pin_um = 0\nsigma_bushing_um = 1.49\n",
    ],
)
def test_the_boundaries_of_the_plausible_small_end_are_accepted(tmp_path, text):
    _case(tmp_path, text)


@pytest.mark.serial
def test_every_shipped_case_is_plausible():
    """The rules refuse no shipped case (nor the sweep's clearances 5-15 um: c/R 5e-4 to 1.5e-3)."""
    files = sorted((ROOT / "cases").glob("*/case.toml"))
    assert len(files) >= 9
    for file in files:
        load_case(file)
    for clearance in (5e-6, 10e-6, 15e-6):
        check_geometry(radius=0.01, width=0.02, clearance=clearance, sigma=0.316e-6)


@pytest.mark.serial
def test_the_command_line_names_flags_in_metres():
    """--radius 12 --width 22 --clearance 0.012 (mm meant): the radius is refused first, 12 m > 1 m."""
    with pytest.raises(InputError) as err:
        check_geometry(radius=12.0, width=22.0, clearance=0.012, names=FLAG_LENGTHS)
    assert str(err.value) == (
        "--radius = 12 is out of range (allowed: [0.0001, 1] m; if you meant 12 mm: --radius 0.012)"
    )


@pytest.mark.serial
def test_the_sections_not_in_the_case_file_are_named(tmp_path):
    """An empty file is all defaults (the reference engine); a partial one names what it lacks; the
    reference case spells out every section."""
    empty = _case(tmp_path, "")
    # [big_end_surface], [pin_boss_surface]: not defaulted, their absent keys are [surface]'s (INHERITED)
    assert empty.defaulted == tuple(
        section for section in SECTIONS if section not in ("big_end_surface", "pin_boss_surface")
    )
    assert defaults_note(empty) == (
        "the case file has no section: every default is used, the reference engine ([engine], [gas], "
        "[small_end], [big_end], [pin_boss], [oil], [surface], [solver])"
    )
    partial = _case(tmp_path, "[engine]\nspeed_rpm = 3000\n[solver]\nstep_deg = 2\n")
    assert defaults_note(partial) == (
        "sections not in the case file, defaults used: [gas], [small_end], [big_end], [pin_boss], [oil], "
        "[surface]"
    )
    assert defaults_note(load_case(ROOT / "cases" / "reference-2000rpm")) is None
    assert re.search("defaulted", repr(empty)) is None  # not a parameter of the case
