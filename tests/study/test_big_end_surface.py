"""The big end's own surface (``[big_end_surface]``): read from the case and handed to the big end's joint.

References: the case file itself (a key given in ``[big_end_surface]`` is its value; a key not given is the
case's ``[surface]`` value, given or default, typed in again here); the Lankarani-Nikravesh stiffness of the
dry joint from its closed form ``K = 4/3 E* sqrt(R R_b / c)`` written out here; the Winkler shell's and the
Patir-Cheng roughness' inputs compared with the section's values. The films are not built (their factory is
replaced by one that returns the FilmSpec it is given), so these are fast.
"""

from __future__ import annotations

import dataclasses
import math
import types

import pytest

from solver.case import BigEndSurface, Case, Surface, load_case
from solver.dynamics.engine import engine_from_case
from solver.dynamics.joint import (
    DryContactJoint,
    FilmJoint,
    JournalFrameFilmJoint,
    big_end_joint_from_case,
    joint_from_case,
)
from solver.errors import InputError
from solver.study.sweep import expand, load_sweep
from tests.conftest import ROOT
from tests.study.test_big_end import make_case

SURFACE = (
    "\n[surface]\nsigma_pin_um = 0.1\nsigma_bushing_um = 0.4\nE_bushing_GPa = 100.0\n"
    "asperity_friction = 0.12\n"
)


def _case(tmp_path, big_end: str, big_end_surface: str | None, solver: str = 'joint = "ideal"\n') -> Case:
    """The reference case (its [surface] replaced by SURFACE) with a [big_end] and, if given, a
    [big_end_surface] section."""
    directory = make_case(tmp_path / "case", solver, big_end)
    text = (directory / "case.toml").read_text()
    head, tail = text.split("[surface]", 1)
    tail = tail[tail.index("\n[") :]  # the sections after [surface]
    extra = "" if big_end_surface is None else f"\n[big_end_surface]\n{big_end_surface}"
    (directory / "case.toml").write_text(head + SURFACE.lstrip("\n") + extra + tail)
    return load_case(directory)


@pytest.fixture
def captured_specs(monkeypatch):
    """The FilmSpecs the film factory is asked for (no film built)."""
    specs = []

    def fake_make_film(spec, comm):
        specs.append(spec)
        return types.SimpleNamespace(spec=spec, has_history=False, set_bushing_angle=lambda angle: None)

    monkeypatch.setattr("solver.film.factory.make_film", fake_make_film)
    return specs


@pytest.mark.serial
def test_without_the_section_the_big_end_surface_is_the_case_surface(tmp_path):
    """No [big_end_surface]: every field equals [surface]'s (the given ones and the defaults), so every
    existing case keeps its big end."""
    case = _case(tmp_path, 'joint = "short-bearing"\n', None)
    assert case.surface.sigma_bushing == pytest.approx(0.4e-6, rel=1e-15)  # the non-default [surface]
    assert dataclasses.asdict(case.big_end_surface) == dataclasses.asdict(case.surface)
    assert isinstance(case.big_end_surface, BigEndSurface)
    assert "big_end_surface" not in case.defaulted  # inherited, not defaulted


@pytest.mark.serial
def test_a_partial_section_changes_its_keys_and_inherits_the_rest(tmp_path):
    """sigma_pin_um and nu_bushing given: those are the section's; the rest is [surface]'s, the given
    non-default values (sigma_bushing 0.4 um, E_bushing 100 GPa, asperity friction 0.12) and the defaults
    (E_pin 210 GPa); the small end keeps [surface]."""
    case = _case(tmp_path, 'joint = "short-bearing"\n', "sigma_pin_um = 0.05\nnu_bushing = 0.25\n")
    be, se = case.big_end_surface, case.surface
    assert be.sigma_pin == pytest.approx(0.05e-6, rel=1e-15)
    assert be.nu_bushing == 0.25
    assert be.sigma_bushing == pytest.approx(0.4e-6, rel=1e-15)
    assert be.E_bushing == pytest.approx(100e9, rel=1e-15)
    assert be.asperity_friction == 0.12
    assert be.E_pin == pytest.approx(210e9, rel=1e-15)
    assert be.sigma == pytest.approx(math.hypot(0.05e-6, 0.4e-6), rel=1e-15)
    assert (se.sigma_pin, se.nu_bushing) == pytest.approx((0.1e-6, 0.33), rel=1e-15)
    changed = {k for k, v in dataclasses.asdict(be).items() if v != getattr(se, k)}
    assert changed == {"sigma_pin", "nu_bushing"}


@pytest.mark.serial
@pytest.mark.parametrize(
    "text, message",
    [
        ("sigma_pin_um = -0.1\n", r"^big_end_surface.sigma_pin_um = -0.1 is out of range \(allowed: >= 0\)$"),
        ("nu_pin = 0.7\n", r"^big_end_surface.nu_pin = 0.7 is out of range"),
        ('E_pin_GPa = "steel"\n', r"^big_end_surface.E_pin_GPa = 'steel' has the wrong type"),
        (
            "sigma_pin = 1\n",
            r"unknown key big_end_surface.sigma_pin \(did you mean big_end_surface.sigma_pin_um",
        ),
        ("sigma_pin_um = 0\nsigma_bushing_um = 0\n", r"^big_end_surface.sigma_pin_um and big_end_surface"),
    ],
)
def test_bad_values_name_the_big_end_surface_key(tmp_path, text, message):
    """One line naming big_end_surface.<key> (not surface.<key>)."""
    with pytest.raises(InputError, match=message) as caught:
        _case(tmp_path, 'joint = "short-bearing"\n', text)
    assert "\n" not in str(caught.value)
    with pytest.raises(InputError, match=r"^big_end_surface.nu_pin = 0.6 is out of range"):
        BigEndSurface(nu_pin=0.6)
    with pytest.raises(InputError, match=r"^surface.nu_pin = 0.6 is out of range"):
        Surface(nu_pin=0.6)


@pytest.mark.serial
@pytest.mark.parametrize("supply", ["none", "hole"])
def test_the_big_end_film_takes_the_big_end_surface(tmp_path, captured_specs, supply):
    """The mixed-fem big end's roughness, asperity contact and Winkler shell are [big_end_surface]'s:
    with the hole the film is in the crankpin's frame, its "journal" the big eye's shell (sigma_bushing,
    E_bushing) and its "bushing" the crankpin (sigma_pin, E_pin). The small end's film keeps [surface]."""
    big_end = 'joint = "mixed-fem"\nelastic = "winkler"\nbushing_thickness_mm = 1.5\n'
    if supply == "hole":
        big_end += 'supply = "hole"\nsupply_pressure_bar = 3.0\n'
    section = "sigma_pin_um = 0.05\nsigma_bushing_um = 0.2\nE_bushing_GPa = 80.0\nnu_bushing = 0.3\n"
    case = _case(tmp_path, big_end, section)
    engine = engine_from_case(case)
    joint = big_end_joint_from_case(case, engine, comm=object())
    assert isinstance(joint, JournalFrameFilmJoint if supply == "hole" else FilmJoint)
    (spec,) = captured_specs
    sigmas = (spec.roughness.sigma_bushing, spec.roughness.sigma_journal)
    pin, shell = sigmas if supply == "hole" else sigmas[::-1]
    assert (pin, shell) == pytest.approx((0.05e-6, 0.2e-6), rel=1e-15)
    assert spec.contact.sigma == pytest.approx(math.hypot(0.05e-6, 0.2e-6), rel=1e-15)
    assert (spec.bushing.E, spec.bushing.nu) == pytest.approx((80e9, 0.3), rel=1e-15)
    # the small end's film: [surface] (sigma 0.1 and 0.4 um)
    joint_from_case(case, engine, object(), "mixed-fem")
    small = captured_specs[-1]
    assert (small.roughness.sigma_journal, small.roughness.sigma_bushing) == pytest.approx(
        (0.1e-6, 0.4e-6), rel=1e-15
    )


@pytest.mark.serial
def test_the_dry_big_end_takes_the_big_end_surface(tmp_path):
    """The dry big end's Hertz stiffness (closed form here), friction, restitution and impact speed are
    [big_end_surface]'s; the stiffness differs from [surface]'s (E_bushing 100 -> 70 GPa)."""
    section = "E_bushing_GPa = 70.0\nasperity_friction = 0.2\nrestitution = 0.5\nimpact_speed_m_s = 0.3\n"
    case = _case(tmp_path, 'joint = "dry"\n', section)
    joint = big_end_joint_from_case(case)
    assert isinstance(joint, DryContactJoint)
    R, c = case.big_end.radius, case.big_end.clearance

    def stiffness(E_bushing):
        E_star = 1 / ((1 - 0.3**2) / 210e9 + (1 - 0.33**2) / E_bushing)
        return 4 / 3 * E_star * math.sqrt(R * (R + c) / c)

    assert joint.stiffness == pytest.approx(stiffness(70e9), rel=1e-12)  # round-off of the two forms
    assert joint.stiffness / stiffness(100e9) == pytest.approx(stiffness(70e9) / stiffness(100e9), rel=1e-12)
    assert stiffness(70e9) / stiffness(100e9) < 0.85  # a real change, not round-off
    assert (joint.friction, joint.restitution, joint.impact_speed) == (0.2, 0.5, 0.3)


@pytest.mark.serial
def test_a_sweep_over_a_big_end_surface_key(tmp_path):
    """A sweep key big_end_surface.sigma_pin_um is a case key (validated by section, its range checked);
    the expanded cases read it, [surface] unchanged."""
    base = ROOT / "cases" / "reference-2000rpm"
    (tmp_path / "sweep.toml").write_text(
        f'[sweep]\nbase = "{base}"\n[sweep.parameters]\n"big_end_surface.sigma_pin_um" = [0.05, 0.2]\n'
    )
    sweep = load_sweep(tmp_path / "sweep.toml", tmp_path / "cases")
    assert sweep.keys == ["big_end_surface.sigma_pin_um"]
    cases = [load_case(directory) for directory in expand(sweep)]
    assert [c.big_end_surface.sigma_pin for c in cases] == pytest.approx([0.05e-6, 0.2e-6], rel=1e-15)
    assert [c.surface.sigma_pin for c in cases] == pytest.approx([0.1e-6, 0.1e-6], rel=1e-15)
    (tmp_path / "bad.toml").write_text(
        f'[sweep]\nbase = "{base}"\n[sweep.parameters]\n"big_end_surface.sigma_pin_um" = [-1.0]\n'
    )
    with pytest.raises(InputError, match=r"big_end_surface.sigma_pin_um = -1 is out of range"):
        expand(load_sweep(tmp_path / "bad.toml", tmp_path / "bad"))
