"""The report's figures: matplotlib drawn to inline SVG strings (no file, no font, no network)."""

from __future__ import annotations

import io
import re
from collections.abc import Sequence

import numpy as np

from .accuracy import AccuracyMap
from .residuals import MeasurementResiduals

_counter = [0]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    plt.rcParams.update({
        "svg.fonttype": "path",  # glyphs as paths: the page needs no font
        "svg.hashsalt": "deltacal",  # the same figure gives the same SVG
        "font.size": 9,
        "axes.titlesize": 10,
        "figure.dpi": 100,
    })
    return plt


def to_svg(fig) -> str:
    """The figure as an inline ``<svg>`` element that scales with the page, with ids unique in it."""
    plt = _pyplot()
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight", dpi=150, metadata={"Date": None})
    plt.close(fig)
    text = buf.getvalue()
    text = text[text.index("<svg"):]
    _counter[0] += 1
    prefix = f"f{_counter[0]}-"
    text = re.sub(r'\bid="([^"]+)"', lambda m: f'id="{prefix}{m.group(1)}"', text)
    text = re.sub(r'href="#([^"]+)"', lambda m: f'href="#{prefix}{m.group(1)}"', text)
    text = re.sub(r"url\(#([^)]+)\)", lambda m: f"url(#{prefix}{m.group(1)})", text)
    # scale with the page: the viewBox stays, the fixed size goes
    head_end = text.index(">")
    head = re.sub(r'\s(width|height)="[^"]*"', "", text[:head_end])
    return head + ' class="figure" preserveAspectRatio="xMidYMid meet"' + text[head_end:]


def length_unit(largest: float) -> tuple[str, float]:
    """Unit to show lengths up to ``largest`` mm in: (``"µm"``, 1000) below 0.5 mm, else (``"mm"``, 1)."""
    return ("µm", 1000.0) if largest < 0.5 else ("mm", 1.0)


def residuals_by_pose(res: MeasurementResiduals) -> str:
    """Residual of each measurement before and after calibration, by pose index; outliers marked."""
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 4.6), sharex=True)
    k = np.arange(1, len(res.lines) + 1)
    for ax, values, title, colour in ((axes[0], res.before, "before (nominal geometry)", "#b35806"),
                                      (axes[1], res.after, "after (identified geometry)", "#2166ac")):
        unit, scale = length_unit(float(np.nanmax(values)) if np.any(np.isfinite(values)) else 1.0)
        ax.vlines(k, 0.0, values * scale, color=colour, lw=1.0)
        ax.plot(k, values * scale, "o", ms=2.5, color=colour)
        ax.set_ylabel(f"{res.kind} residual [{unit}]")
        ax.set_title(title, loc="left")
        ax.set_ylim(bottom=0.0)
        ax.grid(alpha=0.3)
        for i in np.flatnonzero(res.outlier):
            ax.plot(k[i], values[i] * scale, "o", ms=8, mfc="none", mec="#d7191c", mew=1.5)
            ax.annotate(f"line {int(res.lines[i])}", (k[i], values[i] * scale), xytext=(4, 4),
                        textcoords="offset points", color="#d7191c", fontsize=8)
    axes[1].set_xlabel("measurement (pose) index")
    fig.tight_layout()
    return to_svg(fig)


def residuals_over_workspace(res: MeasurementResiduals) -> str:
    """Residual after calibration at each measured place: top view and side view; outliers marked."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 3.4), layout="constrained")
    unit, scale = length_unit(float(np.nanmax(res.after)))
    p = res.position
    sc = None
    for ax, (a, b), names in ((axes[0], (0, 1), ("x", "y")), (axes[1], (0, 2), ("x", "z"))):
        sc = ax.scatter(p[:, a], p[:, b], c=res.after * scale, cmap="viridis", s=18, vmin=0.0,
                        vmax=float(np.nanmax(res.after)) * scale)
        for i in np.flatnonzero(res.outlier):
            ax.scatter(p[i, a], p[i, b], s=80, facecolors="none", edgecolors="#d7191c", linewidths=1.5)
            ax.annotate(f"line {int(res.lines[i])}", (p[i, a], p[i, b]), xytext=(4, 4),
                        textcoords="offset points", color="#d7191c", fontsize=8)
        ax.set_xlabel(f"{names[0]} [mm]")
        ax.set_ylabel(f"{names[1]} [mm]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].set_title("top view", loc="left")
    axes[1].set_title("side view", loc="left")
    fig.colorbar(sc, ax=axes, label=f"residual after [{unit}]", shrink=0.9)
    return to_svg(fig)


def correlation_heatmap(names: Sequence[str], correlation: np.ndarray) -> str:
    """The correlation matrix of the base parameters as a heat map (−1 blue, +1 red)."""
    plt = _pyplot()
    n = len(names)
    size = min(max(4.0, 0.16 * n + 2.0), 9.0)
    fig, ax = plt.subplots(figsize=(size + 1.0, size))
    im = ax.imshow(correlation, cmap="RdBu_r", vmin=-1.0, vmax=1.0, interpolation="nearest")
    fs = max(4.0, min(8.0, 260.0 / max(n, 1)))
    ax.set_xticks(range(n), names, rotation=90, fontsize=fs)
    ax.set_yticks(range(n), names, fontsize=fs)
    fig.colorbar(im, ax=ax, label="correlation", shrink=0.8)
    fig.tight_layout()
    return to_svg(fig)


def _slice_panels(amap: AccuracyMap, values: list[np.ndarray], label: str, top: float,
                  cmap: str, measured: np.ndarray | None, mark_worst: bool) -> str:
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(7.5, 6.6), layout="constrained")
    unit, scale = length_unit(top)
    height = max(float(np.ptp(amap.slices[3].v)), 1e-9)
    im = None
    for ax, s, v in zip(axes.ravel(), amap.slices, values, strict=True):
        im = ax.pcolormesh(s.u, s.v, np.ma.masked_invalid(v * scale), cmap=cmap, vmin=0.0, vmax=top * scale,
                           shading="nearest", rasterized=True, antialiased=False, edgecolors="none")
        ax.set_title(s.label, loc="left")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]" if s.horizontal else "z [mm]")
        ax.set_aspect("equal" if s.horizontal else "auto")
        if measured is not None and len(measured):
            if s.horizontal:
                z = float(np.nanmean(s.points[..., 2]))
                near = np.abs(measured[:, 2] - z) < height / 4.0
                ax.plot(measured[near, 0], measured[near, 1], ".", ms=5, color="white", mec="black", mew=0.4)
            else:
                near = np.abs(measured[:, 1]) < 0.25 * float(np.ptp(s.u))
                ax.plot(measured[near, 0], measured[near, 2], ".", ms=5, color="white", mec="black", mew=0.4)
        if mark_worst:
            w = amap.worst_point
            on = (s.horizontal and abs(float(np.nanmean(s.points[..., 2])) - w[2]) < 1e-6) or (
                not s.horizontal and abs(w[1]) < 1e-6)
            if on:
                ax.plot(w[0], w[1] if s.horizontal else w[2], "*", ms=14, color="#d7191c", mec="white")
    fig.colorbar(im, ax=axes, label=f"{label} [{unit}]", shrink=0.85)
    return to_svg(fig)


def accuracy_slices(amap: AccuracyMap, measured: np.ndarray | None = None) -> str:
    """Predicted 3-D σ of the TCP on the workspace slices, largest marked, measured places as dots."""
    return _slice_panels(amap, amap.sigma, "predicted σ of the TCP position (3-D)", amap.worst,
                         "magma_r", measured, True)


def error_slices(amap: AccuracyMap) -> str:
    """Actual TCP error norm (true robot vs identified model) on the same slices."""
    assert amap.error is not None
    top = float(np.nanmax(np.concatenate([e.ravel() for e in amap.error])))
    return _slice_panels(amap, amap.error, "actual TCP error |p_true − target|", top, "magma_r", None, False)


def error_vs_sigma(amap: AccuracyMap) -> str:
    """Actual error against predicted σ at every slice point, with the lines error = σ and 2σ."""
    assert amap.error is not None
    plt = _pyplot()
    s = np.concatenate([v.ravel() for v in amap.sigma])
    e = np.concatenate([v.ravel() for v in amap.error])
    ok = np.isfinite(s) & np.isfinite(e)
    unit, scale = length_unit(float(max(np.max(s[ok]), np.max(e[ok]))))
    fig, ax = plt.subplots(figsize=(4.6, 4.0))
    ax.plot(s[ok] * scale, e[ok] * scale, ".", ms=2, alpha=0.5, color="#2166ac", rasterized=True)
    top = float(max(np.max(s[ok]), np.max(e[ok]))) * scale * 1.05
    ax.plot([0, top], [0, top], "-", color="k", lw=1, label="error = σ")
    ax.plot([0, top / 2], [0, top], "--", color="k", lw=1, label="error = 2σ")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_xlabel(f"predicted σ (3-D) [{unit}]")
    ax.set_ylabel(f"actual error [{unit}]")
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return to_svg(fig)
