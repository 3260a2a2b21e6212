# SPDX-License-Identifier: LGPL-2.1-or-later
"""The package's layers, read from the code with ``ast`` (every import, at module level or inside
a function): who may import whom, and no import circles between modules.

    core            numpy/scipy only, nothing of ours above it, never FreeCAD
    samples         synthetic blades: core only
    fc              FreeCAD/Part adapters: core (never gui, cli, report)
    acquire         serial reading and the instrument simulator: core, samples
    report          HTML/PNG reports: fc, core
    gui, cli        the two front ends: anything below them, never each other
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "bladerecon"

MAY_IMPORT = {
    "core": {"core"},
    "samples": {"samples", "core"},
    "fc": {"fc", "core"},
    "acquire": {"acquire", "core", "samples"},
    "report": {"report", "fc", "core"},
    "gui": {"gui", "fc", "core", "report", "acquire", "samples"},
    "cli": {"cli", "fc", "core", "report", "acquire", "samples"},
    "": {"core"},        # bladerecon/__init__.py, __main__.py (which starts the cli)
}
FREECAD_MODULES = {"FreeCAD", "FreeCADGui", "Part", "pivy", "PySide", "PySide2", "PySide6"}


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The modules ``name`` imports (ours resolved to the longest known module; others as written)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(up + ([base] if base else []))
            targets = [f"{base}.{a.name}" for a in node.names] + [base]
        else:
            continue
        for t in filter(None, targets):
            found.add(_resolve(t, known))
    found.discard(name)
    return found


def _resolve(target: str, known: set[str]) -> str:
    """``from pkg.mod import name`` names ``pkg.mod.name``: the longest known module in it (or
    the name as written when none is known)."""
    t = target
    while t not in known and "." in t:
        t = t.rpartition(".")[0]
    if t in known and t != "bladerecon":
        return t
    parts = target.split(".")
    if parts[0] == "bladerecon" and len(parts) > 1 and parts[1] not in MAY_IMPORT:
        return "bladerecon"      # a name of the package root (``from bladerecon import __version__``)
    return target


def layer(name: str) -> str:
    parts = name.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in MAY_IMPORT else ""


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    mods = modules()
    known = set(mods)
    return {name: imports_of(name, path, known) for name, path in mods.items()}


def test_every_module_is_in_a_known_layer(graph):
    strays = [m for m in graph if m.count(".") >= 1 and layer(m) == "" and m not in ("bladerecon.__main__",)]
    assert not strays, f"modules outside the layers {sorted(MAY_IMPORT)}: {strays}"


def climbs(graph: dict[str, set[str]]) -> list[str]:
    wrong = []
    for name, targets in graph.items():
        allowed = MAY_IMPORT[layer(name)] | ({"cli"} if name == "bladerecon.__main__" else set())
        for t in targets:
            if t == "bladerecon" or not t.startswith("bladerecon."):
                continue
            if layer(t) not in allowed:
                wrong.append(f"{name} -> {t}")
    return sorted(wrong)


def test_each_layer_imports_only_what_it_may(graph):
    wrong = climbs(graph)
    assert not wrong, "imports against the layers:\n" + "\n".join(wrong)


def test_core_and_samples_never_import_freecad(graph):
    wrong = [f"{n} -> {t}" for n, ts in graph.items() if layer(n) in ("core", "samples")
             for t in ts if t.split(".")[0] in FREECAD_MODULES]
    assert not wrong, wrong


def test_fc_never_imports_the_gui_toolkit(graph):
    wrong = [f"{n} -> {t}" for n, ts in graph.items() if layer(n) == "fc"
             for t in ts if t.split(".")[0] in {"FreeCADGui", "pivy", "PySide", "PySide2", "PySide6"}]
    assert not wrong, wrong


def circles_in(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components over our modules with more than one module."""
    ours = {n: {t for t in ts if t in graph} for n, ts in graph.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in ours[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(ours):
        if v not in index:
            visit(v)
    return circles


def test_no_import_circles(graph):
    circles = circles_in(graph)
    assert not circles, f"import circles: {circles}"


def test_the_checker_sees_a_circle_and_a_climb(tmp_path):
    """The reading above is not blind: a made-up fc module importing gui, and a pair of
    modules importing each other, are both found."""
    fc = tmp_path / "bladerecon" / "fc"
    fc.mkdir(parents=True)
    (tmp_path / "bladerecon" / "__init__.py").write_text("")
    (fc / "__init__.py").write_text("")
    (fc / "a.py").write_text("from bladerecon.gui import view_providers\nfrom . import b\n")
    (fc / "b.py").write_text("def f():\n    from bladerecon.fc import a\n")
    known = {"bladerecon", "bladerecon.fc", "bladerecon.fc.a", "bladerecon.fc.b"}
    global PACKAGE
    saved, PACKAGE = PACKAGE, tmp_path / "bladerecon"
    try:
        a = imports_of("bladerecon.fc.a", fc / "a.py", known)
        b = imports_of("bladerecon.fc.b", fc / "b.py", known)
    finally:
        PACKAGE = saved
    made_up = {"bladerecon.fc.a": a, "bladerecon.fc.b": b}
    assert "bladerecon.fc.a -> bladerecon.gui.view_providers" in climbs(made_up)
    assert circles_in(made_up) == [["bladerecon.fc.a", "bladerecon.fc.b"]]
