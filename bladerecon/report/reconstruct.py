# SPDX-License-Identifier: LGPL-2.1-or-later
"""The report folder of ``reconstruct --report DIR``: summary, per-point CSV, plots (mm).

Files are first written to a temporary folder beside DIR and moved in only when all of them
are complete, so an interrupted run never leaves a report that looks finished. Other files
already in DIR are left alone.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile

import numpy as np

from bladerecon.core.io.outputs import check_folder_target, os_error

__all__ = ["write_report"]

_README = """BladeRecon reconstruction report (all lengths in mm)

summary.json        the run summary (same object as --json prints)
points.csv          one row per measured point: section, line (in the input file), x, y, z,
                    fit_distance (point to reconstructed surface, unsigned),
                    fit_signed (+ outside the surface, i.e. along S_u x S_v),
                    nominal_signed (point to nominal, + outside the nominal; empty without --nominal)
surface_vs_nominal.csv   reconstructed surface samples: u, v, x, y, z, signed distance to the nominal
fit.png             distance of every measured point to the surface, per section around the profile
nominal.png         surface-to-nominal deviation map unrolled in (u, v)
"""


def _plot_fit(path: str, sections, proj) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 4.5), dpi=110)
    start = 0
    for sec in sections.sections:
        n = len(sec.points)
        d = proj.signed[start : start + n] * 1000.0
        ax.plot(np.arange(n) / n, d, ".", ms=2, label=f"section {sec.name}")
        start += n
    ax.set_xlabel("position around the section (fraction of its points, from the first measured point)")
    ax.set_ylabel("measured point − surface, signed (µm)")
    ax.set_title("Fit residuals of the measured points")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, markerscale=4, ncol=3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _plot_nominal(path: str, uv: np.ndarray, dev: np.ndarray) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 4.5), dpi=110)
    lim = max(np.abs(dev).max() * 1000.0, 1e-3)
    sc = ax.scatter(uv[:, 0], uv[:, 1], c=dev * 1000.0, s=6, cmap="coolwarm", vmin=-lim, vmax=lim)
    fig.colorbar(sc, ax=ax, label="surface − nominal (µm), + = outside")
    ax.set_xlabel("u (around the section; 0 = leading edge)")
    ax.set_ylabel("v (span, hub → tip)")
    ax.set_title("Reconstructed surface against the nominal")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_report(folder: str, summary: dict, sections, measured: np.ndarray, proj, nominal_dev) -> None:
    """Write the report files into ``folder`` (created if missing) atomically, file set at once.

    A ``folder`` that is a file, device or link is refused; an OS failure (disk full, read-only)
    is one :class:`BladeReconError` line naming ``folder``.
    """
    check_folder_target(folder, "report folder", force=True)
    try:
        _write_report(folder, summary, sections, measured, proj, nominal_dev)
    except OSError as err:
        raise os_error(err, folder) from None


def _write_report(folder, summary, sections, measured, proj, nominal_dev) -> None:
    folder = os.path.abspath(folder)
    parent = os.path.dirname(folder)
    tmp = tempfile.mkdtemp(prefix=".bladerecon-report-", dir=parent)
    try:
        with open(os.path.join(tmp, "summary.json"), "w", encoding="utf-8") as fh:
            json.dump(summary, fh, indent=2)
        with open(os.path.join(tmp, "README.txt"), "w", encoding="utf-8") as fh:
            fh.write(_README)
        sec_name = np.concatenate([[s.name] * len(s.points) for s in sections.sections])
        lines = np.concatenate([s.lines for s in sections.sections])
        nom = nominal_dev[3] if nominal_dev is not None else None
        nominal = [f"{x:.6f}" for x in nom] if nom is not None else [""] * measured.shape[0]
        table = np.empty((measured.shape[0], 8), dtype=object)
        table[:, 0], table[:, 1], table[:, 2:5] = sec_name, lines, measured
        table[:, 5], table[:, 6], table[:, 7] = proj.distance, proj.signed, nominal
        np.savetxt(os.path.join(tmp, "points.csv"), table, delimiter=",", encoding="utf-8",
                   fmt=["%s", "%d", "%.6f", "%.6f", "%.6f", "%.6f", "%.6f", "%s"],
                   header="section,line,x,y,z,fit_distance,fit_signed,nominal_signed", comments="")
        _plot_fit(os.path.join(tmp, "fit.png"), sections, proj)
        if nominal_dev is not None:
            uv, samples, dev, _ = nominal_dev
            table = np.column_stack([uv, samples, dev])
            np.savetxt(os.path.join(tmp, "surface_vs_nominal.csv"), table, delimiter=",", fmt="%.6f",
                       header="u,v,x,y,z,signed_mm", comments="")
            _plot_nominal(os.path.join(tmp, "nominal.png"), uv, dev)
        os.makedirs(folder, exist_ok=True)
        for name in os.listdir(tmp):
            os.replace(os.path.join(tmp, name), os.path.join(folder, name))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
