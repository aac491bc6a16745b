"""Sweep files: one TOML that names a base case and the parameters to vary -> case directories.

Format (every key of ``[sweep.set]`` and ``[sweep.parameters]`` is a case key ``section.key`` of
solver.case.FIELDS, in the units of its name)::

    [sweep]
    base = "../cases/reference-2000rpm"  # base case directory (or case TOML file), relative to this file
    cases_dir = "clearance-study"        # optional; default: a directory named after this file, beside it
    mode = "product"                     # optional; "product" (default) or "zip"

    [sweep.set]                          # optional: the same overrides in every case
    "solver.joint" = "short-bearing"
    "solver.max_cycles" = 2

    [sweep.parameters]                   # the varied parameters, in this order
    "engine.speed_rpm" = [1000, 2000, 4000]                      # a list of values
    "small_end.clearance_um" = {start = 5, stop = 15, num = 3}   # num values, both ends included
    "oil.viscosity_Pa_s" = {start = 0.005, stop = 0.02, step = 0.005}  # start + i step, up to stop

Keys may be quoted (``"engine.speed_rpm" = ...``) or written as TOML dotted keys / sub-tables
(``engine.speed_rpm = ...``, ``[sweep.parameters.engine]``): both mean the same.

Expansion (reproducible: the same sweep file and base give the same directories and files, byte for
byte):

- ``mode = "product"``: the cartesian product in the order the parameters are written; the first
  parameter varies slowest, the last fastest (``itertools.product``). ``mode = "zip"``: all lists have
  the same length and the i-th case takes the i-th value of each.
- ranges: ``{start, stop, num}`` is ``numpy.linspace(start, stop, num)``; ``{start, stop, step}`` is
  ``start + i * step`` for i = 0, 1, ... while the value does not pass ``stop`` (within 1e-9 step, so
  ``stop`` is included when it lies on the grid). Integers stay integers. Values are rounded to 12
  significant digits, so that 0.1 + 0.2 is written as 0.3.
- names: ``<key>-<value>`` for each varied parameter, joined by ``_``, with the key without its
  section (``speed_rpm-1000_clearance_um-10``; the full ``section.key`` if two sections share a key),
  values as ``%.12g`` (strings with every character other than letters, digits, ``.``, ``+``, ``-``
  replaced by ``-``). Two cases with the same name are an error.
- each case directory holds ``case.toml``: the base case's keys with ``[sweep.set]`` and the case's
  values put in, ``name`` = the directory name and a description that lists the case's values, written
  out in the order of solver.case.FIELDS. A pressure or speed CSV that the base (or an override)
  names is copied into the case directory and referred to by its file name, so a case directory is
  self-contained.
- ``<cases_dir>/sweep.json`` lists the sweep: its file, base, mode, the varied keys, and every case
  with its values, in expansion order.

Writing is atomic and idempotent: every case is staged and validated (solver.case.load_case) in a
temporary directory inside ``cases_dir``; if any case is invalid nothing is written and the error
names the case and the key. Each staged case directory is then renamed into place. A case directory
that already exists with the same files is left alone (its results are kept), and one whose
``case.toml`` differs is an error (the base or the sweep changed: delete it to regenerate it).
"""

from __future__ import annotations

import dataclasses
import difflib
import filecmp
import itertools
import json
import math
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

from solver.case import FIELDS, SECTIONS, FieldSpec, load_case
from solver.errors import InputError, read_toml_file

RANGE_KEYS = {"start", "stop", "num", "step"}
MODES = ("product", "zip")
_SPECS = {spec.name: spec for spec in FIELDS if spec.section}
_SAFE = re.compile(r"[^A-Za-z0-9.+-]")


@dataclasses.dataclass(frozen=True)
class Sweep:
    """A parsed sweep file.

    Attributes:
        file: the sweep file.
        base: the base case file (``case.toml`` or a case TOML file).
        cases_dir: where the case directories go.
        mode: ``product`` or ``zip``.
        fixed: ``section.key`` -> value, set in every case (TOML units).
        parameters: ``(section.key, values)`` in the order of the file (TOML units).
    """

    file: Path
    base: Path
    cases_dir: Path
    mode: str
    fixed: dict[str, Any]
    parameters: tuple[tuple[str, tuple[Any, ...]], ...]

    @property
    def keys(self) -> list[str]:
        """The varied keys, in order."""
        return [key for key, _ in self.parameters]

    def cases(self) -> list[dict[str, Any]]:
        """The varied values of every case, in expansion order (``section.key`` -> value)."""
        if self.mode == "zip":
            rows = zip(*(values for _, values in self.parameters))
        else:
            rows = itertools.product(*(values for _, values in self.parameters))
        return [dict(zip(self.keys, row)) for row in rows]

    def names(self) -> list[str]:
        """The case directory names, in expansion order."""
        return [case_name(values) for values in self.cases()]


def is_sweep_file(path: Path) -> bool:
    """True for a TOML file with a ``[sweep]`` table."""
    path = Path(path)
    if not path.is_file() or path.suffix != ".toml":
        return False
    try:
        return isinstance(read_toml_file(path, "sweep file").get("sweep"), dict)
    except InputError:
        return False


def _flatten(table: dict, where: str, prefix: str = "") -> dict[str, Any]:
    """``{"engine": {"speed_rpm": v}}`` and ``{"engine.speed_rpm": v}`` -> ``{"engine.speed_rpm": v}``."""
    flat: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and not (value and set(value) <= RANGE_KEYS):
            flat.update(_flatten(value, where, prefix=f"{name}."))
        else:
            if name in flat:
                raise InputError(f"{where}: {name} is given twice")
            flat[name] = value
    return flat


def _spec(name: str, where: str) -> FieldSpec:
    if name in _SPECS:
        spec = _SPECS[name]
        if spec.kind is list:
            raise InputError(f"{where}: {name} cannot be swept (a list-valued key); put it in the base case")
        return spec
    if name in ("name", "description"):
        raise InputError(f"{where}: {name} cannot be set by a sweep (case names are made from the values)")
    close = difflib.get_close_matches(name, list(_SPECS), n=1)
    section = name.split(".")[0]
    if close:
        hint = f"did you mean {close[0]}?"
    elif section not in SECTIONS:
        hint = f"keys are section.key with a section of {', '.join(SECTIONS)}"
    else:
        hint = "see the case keys in the README"
    raise InputError(f"{where}: unknown case key {name} ({hint})")


def _check_value(spec: FieldSpec, value: Any, where: str) -> Any:
    """Type check of one value (ranges are checked by load_case on the expanded case)."""
    expected = None
    if spec.kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            expected = "a number"
    elif spec.kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            expected = "an integer"
    elif spec.kind is bool:
        if not isinstance(value, bool):
            expected = "true or false"
    elif not isinstance(value, str):
        expected = "a string"
    elif spec.choices and value not in spec.choices:
        raise InputError(f"{where}: {spec.name} = {value!r} is out of range (allowed: {spec.allowed()})")
    if expected:
        raise InputError(f"{where}: {spec.name} = {value!r} has the wrong type (expected {expected})")
    return value


def _round(value: float) -> float:
    return float(f"{value:.12g}")


def _expand_range(spec: FieldSpec, table: dict, where: str) -> list[Any]:
    name = spec.name
    if spec.kind not in (float, int):
        raise InputError(f"{where}: {name}: a range needs a numeric key (give a list of values)")
    if not {"start", "stop"} <= set(table) or ("num" in table) == ("step" in table):
        raise InputError(
            f"{where}: {name}: a range is {{start, stop, num}} or {{start, stop, step}}, "
            f"got {{{', '.join(table)}}}"
        )
    for key, value in table.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{where}: {name}: {key} = {value!r} has the wrong type (expected a number)")
    start, stop = table["start"], table["stop"]
    if "num" in table:
        num = table["num"]
        if not isinstance(num, int) or num < 1:
            raise InputError(f"{where}: {name}: num = {num!r} is out of range (allowed: an integer >= 1)")
        if num == 1:
            values = [start]
        else:
            values = [start + (stop - start) * i / (num - 1) for i in range(num)]
            values[-1] = stop
    else:
        step = table["step"]
        if step == 0 or (stop - start) * step < 0:
            raise InputError(
                f"{where}: {name}: step = {step!r} is out of range "
                f"(allowed: non-zero, from start towards stop)"
            )
        count = math.floor((stop - start) / step + 1e-9) + 1
        if count > 100000:
            raise InputError(f"{where}: {name}: the range has {count} values (allowed: <= 100000)")
        values = [start + i * step for i in range(count)]
    if spec.kind is int:
        if not all(float(v).is_integer() for v in values):
            raise InputError(f"{where}: {name} is an integer key: the range gives non-integer values")
        return [int(round(v)) for v in values]
    integral = all(isinstance(table[k], int) for k in table if k != "num")
    return [int(v) if integral and "step" in table else _round(float(v)) for v in values]


def load_sweep(path: str | Path, cases_dir: str | Path | None = None) -> Sweep:
    """Read and check a sweep file.

    Args:
        path: the sweep TOML file.
        cases_dir: where the case directories go (default: ``[sweep] cases_dir``, else a directory
            named after the sweep file, beside it).

    Raises:
        InputError: one line naming the file and the key.
    """
    file = Path(path).resolve()
    where = str(path)
    data = read_toml_file(path, "sweep file")
    table = data.get("sweep")
    if not isinstance(table, dict):
        raise InputError(f"{where}: no [sweep] table (a sweep file names a base case and the parameters)")
    extra = set(data) - {"sweep"}
    if extra:
        raise InputError(f"{where}: unknown top-level key or table {sorted(extra)[0]} (only [sweep] is read)")
    known = {"base", "cases_dir", "mode", "set", "parameters"}
    for key in table:
        if key not in known:
            close = difflib.get_close_matches(key, sorted(known), n=1)
            hint = f" (did you mean sweep.{close[0]}?)" if close else f" (known: {', '.join(sorted(known))})"
            raise InputError(f"{where}: unknown key sweep.{key}{hint}")

    base_value = table.get("base")
    if not isinstance(base_value, str):
        raise InputError(
            f"{where}: sweep.base is required (the base case directory, relative to the sweep file)"
        )
    base = (file.parent / base_value).resolve()
    base_file = base / "case.toml" if base.is_dir() else base
    if not base_file.is_file():
        raise InputError(f"{where}: sweep.base = {base_value!r}: case file not found ({base_file})")

    mode = table.get("mode", "product")
    if mode not in MODES:
        allowed = ", ".join(map(repr, MODES))
        raise InputError(f"{where}: sweep.mode = {mode!r} is out of range (allowed: {allowed})")

    if cases_dir is None:
        value = table.get("cases_dir", file.stem)
        if not isinstance(value, str) or not value:
            raise InputError(
                f"{where}: sweep.cases_dir = {value!r} has the wrong type (expected a directory name)"
            )
        cases_dir = file.parent / value
    cases_dir = Path(cases_dir).resolve()

    fixed_table = table.get("set", {})
    parameter_table = table.get("parameters")
    if not isinstance(fixed_table, dict):
        raise InputError(f"{where}: sweep.set must be a table of case keys")
    if not isinstance(parameter_table, dict) or not parameter_table:
        raise InputError(f"{where}: [sweep.parameters] is required: case keys with lists or ranges of values")

    fixed = {}
    for name, value in _flatten(fixed_table, where).items():
        spec = _spec(name, f"{where}: sweep.set")
        fixed[name] = _check_value(spec, value, f"{where}: sweep.set")
    parameters = []
    for name, value in _flatten(parameter_table, where).items():
        context = f"{where}: sweep.parameters"
        spec = _spec(name, context)
        if name in fixed:
            raise InputError(f"{where}: {name} is both in sweep.set and in sweep.parameters")
        if isinstance(value, dict):
            values = _expand_range(spec, value, context)
        elif isinstance(value, list):
            if not value:
                raise InputError(f"{context}: {name} = [] has no values")
            values = [_check_value(spec, v, context) for v in value]
        else:
            raise InputError(
                f"{context}: {name} = {value!r} has the wrong type "
                f"(expected a list of values or a range {{start, stop, num|step}})"
            )
        parameters.append((name, tuple(values)))
    if mode == "zip" and len({len(values) for _, values in parameters}) > 1:
        lengths = ", ".join(f"{name}: {len(values)}" for name, values in parameters)
        raise InputError(f"{where}: sweep.mode = 'zip' needs lists of the same length ({lengths})")
    return Sweep(
        file=file, base=base_file, cases_dir=cases_dir, mode=mode, fixed=fixed, parameters=tuple(parameters)
    )


def format_value(value: Any) -> str:
    """A value as it appears in a case name."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.12g}"
    return _SAFE.sub("-", Path(str(value)).stem if "/" in str(value) else str(value))


def case_name(values: dict[str, Any]) -> str:
    """``speed_rpm-1000_clearance_um-10`` for ``{"engine.speed_rpm": 1000, "small_end.clearance_um": 10}``."""
    short = [name.split(".", 1)[1] for name in values]
    parts = []
    for name, key in zip(values, short):
        label = name if short.count(key) > 1 else key
        parts.append(f"{label}-{format_value(values[name])}")
    return "_".join(parts)


# -- writing -------------------------------------------------------------------------------------


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value) or math.isinf(value):
            raise InputError(f"cannot write {value!r} to a case file")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise InputError(f"cannot write {value!r} to a case file")


def case_toml(data: dict[str, Any], header: str) -> str:
    """TOML text of a case dictionary (top-level keys, then the sections in FIELDS order)."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    order = {spec.name: i for i, spec in enumerate(FIELDS)}
    top = {k: v for k, v in data.items() if not isinstance(v, dict)}
    for key in sorted(top, key=lambda k: order.get(k, len(order))):
        lines.append(f"{key} = {_toml_value(top[key])}")
    for section in SECTIONS:
        table = data.get(section)
        if not table:
            continue
        lines += ["", f"[{section}]"]
        for key in sorted(table, key=lambda k: order.get(f"{section}.{k}", len(order))):
            lines.append(f"{key} = {_toml_value(table[key])}")
    return "\n".join(lines) + "\n"


def _case_files(sweep: Sweep, base: dict, values: dict[str, Any], name: str) -> dict[str, Any]:
    """The case dictionary and the data files to copy: ``{"toml": text, "files": {name: source}}``."""
    data = {key: (dict(value) if isinstance(value, dict) else value) for key, value in base.items()}
    for key, value in {**sweep.fixed, **values}.items():
        section, field = key.split(".", 1)
        data.setdefault(section, {})[field] = value
    data["name"] = name
    described = ", ".join(f"{key} = {format_value(value)}" for key, value in values.items())
    base_description = data.get("description", "")
    data["description"] = (
        f"{base_description} | sweep: {described}" if base_description else f"sweep: {described}"
    )
    files: dict[str, Path] = {}
    for spec in FIELDS:
        if spec.kind is not Path or spec.key not in data.get(spec.section, {}):
            continue
        value = data[spec.section][spec.key]
        source = (sweep.base.parent / value).resolve()
        if not source.is_file():
            raise InputError(f"{sweep.file}: case {name}: {spec.name} = {value!r}: file not found ({source})")
        target = source.name
        if target in files and files[target] != source:
            raise InputError(f"{sweep.file}: case {name}: two data files are both called {target}")
        files[target] = source
        data[spec.section][spec.key] = target
    header = (
        f"Generated by the sweep {sweep.file.name} from the base case {sweep.base}.\n"
        f"Regenerate it from the sweep file rather than editing it (python3 -m solver batch "
        f"{sweep.file.name} --list)."
    )
    return {"toml": case_toml(data, header), "files": files}


def _same(directory: Path, staged: Path) -> bool:
    """The existing case directory holds the same case.toml and data files as the staged one."""
    for entry in staged.iterdir():
        existing = directory / entry.name
        if not existing.is_file() or not filecmp.cmp(entry, existing, shallow=False):
            return False
    return True


def _write_if_changed(path: Path, text: str) -> None:
    if path.is_file() and path.read_text() == text:
        return
    fd, part = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as stream:
            stream.write(text)
        os.replace(part, path)
    finally:
        if os.path.exists(part):
            os.unlink(part)


def manifest(sweep: Sweep) -> dict:
    """The content of ``sweep.json``."""
    return {
        "sweep_file": str(sweep.file),
        "base": str(sweep.base),
        "mode": sweep.mode,
        "set": sweep.fixed,
        "parameters": sweep.keys,
        "cases": [{"name": case_name(values), "values": values} for values in sweep.cases()],
    }


def expand(sweep: Sweep) -> list[Path]:
    """Write the case directories of a sweep (atomically, idempotently); return them in order.

    Raises:
        InputError: a case is invalid (nothing is written), two cases have the same name, or an
            existing case directory differs from the expansion.
    """
    base = read_toml_file(sweep.base, "sweep.base case file")
    rows = sweep.cases()
    names = [case_name(values) for values in rows]
    seen: dict[str, int] = {}
    for index, name in enumerate(names):
        if name in seen:
            raise InputError(
                f"{sweep.file}: cases {seen[name] + 1} and {index + 1} both get the name {name} "
                f"(values equal to 12 significant digits)"
            )
        seen[name] = index
    try:
        sweep.cases_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"cases directory {sweep.cases_dir}: cannot create it ({err.strerror})") from None

    staging = Path(tempfile.mkdtemp(prefix=".sweep-", dir=sweep.cases_dir))
    try:
        for name, values in zip(names, rows):
            content = _case_files(sweep, base, values, name)
            staged = staging / name
            staged.mkdir()
            (staged / "case.toml").write_text(content["toml"])
            for target, source in content["files"].items():
                shutil.copyfile(source, staged / target)
            try:
                load_case(staged)
            except InputError as err:
                raise InputError(f"{sweep.file}: case {name}: {err}") from None
            target_dir = sweep.cases_dir / name
            if target_dir.exists() and not _same(target_dir, staged):
                raise InputError(
                    f"{target_dir}: differs from the expansion of {sweep.file.name} (the base "
                    f"case or the sweep changed); delete the directory to regenerate it"
                )
        for name in names:
            target_dir = sweep.cases_dir / name
            if target_dir.exists():
                continue
            try:
                os.rename(staging / name, target_dir)  # atomic; fails if another process made it first
            except OSError:
                if not (target_dir.is_dir() and _same(target_dir, staging / name)):
                    raise InputError(f"{target_dir}: cannot create the case directory") from None
        _write_if_changed(sweep.cases_dir / "sweep.json", json.dumps(manifest(sweep), indent=2) + "\n")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return [sweep.cases_dir / name for name in names]


__all__ = [
    "Sweep",
    "load_sweep",
    "expand",
    "is_sweep_file",
    "case_name",
    "format_value",
    "case_toml",
    "manifest",
]
