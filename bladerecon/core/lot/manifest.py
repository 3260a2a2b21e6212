# SPDX-License-Identifier: LGPL-2.1-or-later
"""The blades of a lot: a manifest CSV ``blade,file[,nominal][,serial][,date]`` or a folder of
point files, and the input hash ``--resume`` compares."""
from __future__ import annotations

import csv
import hashlib
import os
import re
from dataclasses import dataclass

from bladerecon.core.errors import BladeReconError

__all__ = ["LotBlade", "read_manifest", "file_sha256", "POINT_SUFFIXES", "check_blade_name"]

POINT_SUFFIXES = (".csv", ".xyz", ".txt", ".asc", ".pts", ".ply", ".pcd")
_COLUMNS = ("blade", "file", "nominal", "serial", "date")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")
_RESERVED = {"lot", "scan"}          # folders of the lot summary and of a blisk's split scan


@dataclass(frozen=True)
class LotBlade:
    """One blade of the lot: ``name`` (its output folder), ``file`` (absolute), ``shown``
    (the file as the manifest names it), optional ``nominal`` (absolute), serial and date."""

    name: str
    file: str
    shown: str
    nominal: str | None = None
    serial: str = ""
    date: str = ""


def check_blade_name(name: str, where: str) -> None:
    if not _NAME.match(name) or name in _RESERVED:
        raise BladeReconError(f"{where}: blade name {name!r} cannot name a folder: use letters, digits, . _ - "
                              f"(up to 100, not starting with . - _; not {' or '.join(sorted(_RESERVED))})")


def read_manifest(path: str) -> list[LotBlade]:
    """The lot's blades in manifest order (a folder: its point files sorted by name, each
    blade named after its file without the suffix). Paths in a manifest are relative to it."""
    if os.path.isdir(path):
        return _folder(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        raise BladeReconError(f"{path}: no such manifest file or folder") from None
    except (OSError, UnicodeDecodeError) as err:
        raise BladeReconError(f"{path}: cannot read the manifest: {err}") from None
    rows = [r for r in rows if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise BladeReconError(f"{path}: the manifest is empty: give a header blade,file[,nominal][,serial][,date]")
    header = [c.strip().lower() for c in rows[0]]
    unknown = [c for c in header if c not in _COLUMNS]
    if unknown or "blade" not in header or "file" not in header or len(set(header)) != len(header):
        raise BladeReconError(f"{path}, line 1: header {','.join(rows[0])!r}: give the columns blade,file and "
                              "optionally nominal,serial,date (each once)")
    base = os.path.dirname(os.path.abspath(path))
    blades, seen = [], set()
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise BladeReconError(f"{path}, line {line}: {len(row)} cells for {len(header)} columns")
        cell = {k: v.strip() for k, v in zip(header, row)}
        where = f"{path}, line {line}"
        check_blade_name(cell["blade"], where)
        if cell["blade"] in seen:
            raise BladeReconError(f"{where}: blade {cell['blade']!r} appears twice: give each blade its own name")
        if not cell["file"]:
            raise BladeReconError(f"{where}: no file for blade {cell['blade']!r}")
        seen.add(cell["blade"])
        nominal = cell.get("nominal") or None
        blades.append(LotBlade(cell["blade"], os.path.join(base, cell["file"]), cell["file"],
                               os.path.join(base, nominal) if nominal else None,
                               cell.get("serial", ""), cell.get("date", "")))
    if not blades:
        raise BladeReconError(f"{path}: the manifest lists no blades")
    return blades


def _folder(path: str) -> list[LotBlade]:
    names = sorted(n for n in os.listdir(path) if os.path.splitext(n)[1].lower() in POINT_SUFFIXES
                   and os.path.isfile(os.path.join(path, n)))
    if not names:
        raise BladeReconError(f"{path}: the folder holds no point files ({', '.join(POINT_SUFFIXES)})")
    blades, seen = [], set()
    for n in names:
        stem = os.path.splitext(n)[0]
        check_blade_name(stem, f"{path}/{n}")
        if stem in seen:
            raise BladeReconError(f"{path}: two files for blade {stem!r}: keep one")
        seen.add(stem)
        blades.append(LotBlade(stem, os.path.abspath(os.path.join(path, n)), n))
    return blades


def file_sha256(path: str) -> str | None:
    """SHA-256 of the file's bytes (None when it cannot be read: the blade fails later, with
    the reader's message)."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()
