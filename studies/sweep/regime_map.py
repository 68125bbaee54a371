"""The regime map of a sweep directory (``stickslip plot SWEEP_DIR``), with the reduced
model's existence boundaries overlaid (semianalytic.waves)."""

from __future__ import annotations

import itertools
import json
import math
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stickslip.postprocess.style import REGIME_COLORS
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.waves import find_waves, refine_wave
from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import (
    Scene,
    SceneError,
    load_scene,
    scene_to_dict,
)
from stickslip.studies.rundir.readers import ReadError
from stickslip.studies.sweep.spec import (
    _SEMIANALYTIC_KEYS,
    REGIMES,
    SweepError,
    _slug_value,
    _toml_value,
)
from stickslip.studies.sweep.table import _read_json, read_table

# ============================================================================ regime map


def _axis_scale(values: Sequence[float], scale: str) -> str:
    if scale != "auto":
        return scale
    v = [float(x) for x in values]
    return "log" if min(v) > 0 and max(v) / min(v) >= 20 else "linear"


def _edges(values: Sequence[float], scale: str) -> list[float]:
    """Cell edges around sorted ``values``: midpoints (geometric for log axes)."""
    import numpy as np

    v = np.asarray(values, dtype=float)
    t = np.log(v) if scale == "log" else v
    if t.size == 1:
        mid = np.array([t[0] - 0.5, t[0] + 0.5]) if scale == "log" else \
            np.array([t[0] - 0.5 * max(abs(t[0]), 1.0), t[0] + 0.5 * max(abs(t[0]), 1.0)])
    else:
        inner = 0.5 * (t[1:] + t[:-1])
        mid = np.concatenate([[t[0] - (inner[0] - t[0])], inner, [t[-1] + (t[-1] - inner[-1])]])
    return [float(x) for x in (np.exp(mid) if scale == "log" else mid)]


def _refine(values: Sequence[float], scale: str, factor: int) -> list[float]:
    import numpy as np

    v = np.asarray(sorted(values), dtype=float)
    if v.size < 2:
        return list(v)
    t = np.log(v) if scale == "log" else v
    fine = np.concatenate([np.linspace(a, b, factor, endpoint=False) for a, b in
                           zip(t[:-1], t[1:], strict=True)] + [t[-1:]])
    return [float(x) for x in (np.exp(fine) if scale == "log" else fine)]


def _span(values: Sequence[float], scale: str) -> list[float]:
    """``values`` plus the outer cell edges (the map is covered edge to edge).

    On a linear axis a non-positive lower edge is dropped (Ω, δ, f, ξ... must stay > 0).
    """
    if len(values) < 2:
        return list(values)
    e = _edges(values, scale)
    return ([e[0]] if e[0] > 0 else []) + list(values) + [e[-1]]


def _reduced_params(scene: Scene) -> tuple[float, float, float, float, float, float]:
    """(nu, xi, gamma, f, delta, omega) of the reduced model (paper section 2) for ``scene``."""
    g, m, ld = scene.geometry, scene.material, scene.loading
    return (m.nu, g.xi, gamma_from_physical(m.wave_speed, g.R, ld.omega), ld.f, g.delta,
            ld.omega)


def existence_grid(base: Scene, xkey: str, xs: Sequence[float], ykey: str, ys: Sequence[float],
                   ks: Iterable[int], *, regime: str,
                   junctions: Sequence[str] = ("impact",)) -> list[list[int]]:
    """Admissibility (0/1, rows = y) of semi-analytical waves of ``regime`` on an x-y grid.

    Uses ``semianalytic.waves.find_waves`` (eqs. [4]-[7]). A point counts when any wavenumber
    of ``ks`` has an admissible wave. Stick-slip waves: c sqrt(gamma) and psi depend only on
    (nu, xi, f, k) (docs/semianalytic.md), so the multistart runs once per (nu, xi, f, k)
    and each grid point is one Newton step (``refine_wave``) with its own admissibility check;
    stick-slip-separation waves: one multistart per point and k. Points that differ only in
    keys the reduced model does not see (mesh, seed, time step...) are computed once.
    """
    import warnings

    ks = tuple(ks)
    searched: dict[tuple, list] = {}
    seen_points: dict[tuple, int] = {}
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for y in ys:
            row = []
            for x in xs:
                scene = base.with_overrides(f"{xkey}={_toml_value(x)}",
                                            f"{ykey}={_toml_value(y)}")
                nu, xi, gamma, f, delta, _ = _reduced_params(scene)
                if f <= 0 or delta <= 0:
                    row.append(0)
                    continue
                point = (nu, xi, gamma, f, delta)  # all the reduced model sees of the scene
                if point in seen_points:  # an axis the reduced model does not see
                    row.append(seen_points[point])
                    continue
                co = coefficients(nu, xi, gamma)
                ok = False
                for k in ks:
                    if regime == "stick-slip":
                        key = (nu, xi, f, k)
                        if key not in searched:
                            searched[key] = find_waves(co, f, k, delta, regime="stick-slip")
                        for w in searched[key]:
                            r = refine_wave(w, co, f=f, delta=delta)
                            if r is not None and r.admissible:
                                ok = True
                                break
                    else:
                        waves = find_waves(co, f, k, delta, regime="stick-slip-separation",
                                           junctions=tuple(junctions))
                        ok = any(w.admissible for w in waves)
                    if ok:
                        break
                seen_points[point] = int(ok)
                row.append(int(ok))
            out.append(row)
    return out


def _numeric(values: Iterable[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _semianalytic_overlay(sweep_dir: Path, meta: dict, base: Scene, xkey: str, xs: list,
                          xscale: str, ykey: str, ys: list, yscale: str, others: dict,
                          ks: tuple[int, ...]) -> dict:
    """Existence grids for both wave types, cached in ``semianalytic.json`` of the sweep."""
    scene = base.with_overrides(*(f"{k}={_toml_value(v)}" for k, v in others.items()))
    junctions = tuple(meta["map"].get("junctions") or ("impact",))
    # The stick-slip check is one Newton step a point: refine the axes of the reduced model 4x.
    fx = _refine(_span(xs, xscale), xscale, 4) if xkey in _SEMIANALYTIC_KEYS else list(xs)
    fy = _refine(_span(ys, yscale), yscale, 4) if ykey in _SEMIANALYTIC_KEYS else list(ys)
    physics = {k: v for k, v in scene_to_dict(scene).items()
               if k in ("material", "geometry", "loading")}  # all the reduced model sees
    key = json.dumps({"x": xkey, "y": ykey, "xs": xs, "ys": ys, "k": list(ks),
                      "junctions": list(junctions), "scene": physics},
                     sort_keys=True, default=str)
    cache_path = sweep_dir / "semianalytic.json"
    cache = _read_json(cache_path) or {}
    if key in cache:
        return cache[key]
    t0 = time.perf_counter()
    res = {
        "k": list(ks), "junctions": list(junctions),
        "stick-slip": {"x": fx, "y": fy, "admissible": existence_grid(
            scene, xkey, fx, ykey, fy, ks, regime="stick-slip")},
        "stick-slip-separation": {"x": list(xs), "y": list(ys), "admissible": existence_grid(
            scene, xkey, xs, ykey, ys, ks, regime="stick-slip-separation",
            junctions=junctions)},
    }
    res["seconds"] = time.perf_counter() - t0
    cache[key] = res
    try:
        atomic_write_text(cache_path, json.dumps(cache))
    except OSError:  # read-only sweep directory: just don't cache
        pass
    return res


#: The mark of a map cell whose samples alias its wave (``studies.sweep.table.aliased``).
ALIASED = "aliased"


def cell_label(row: dict) -> tuple[str | None, str]:
    """(regime category, text) of a map cell: what the cell's run found.

    A wave reads "k = 4, −2507 m/s" (+ a star when no limit cycle was reached by t_end, and
    a third line "aliased" when the samples alias the wave: then k and the celerity are not
    the run's), steady sliding reads "steady sliding", a failed or diverged run says so, and
    a run that has not finished shows its status.
    """
    status, regime = row.get("status"), row.get("regime")
    if status == "diverged":
        return "diverged", "diverged"
    if status == "failed":
        return "failed", "error"
    if status != "completed" or regime is None:
        return None, str(status or "pending")
    if regime == "steady-sliding":
        return regime, "steady\nsliding"
    star = "" if row.get("limit_cycle") in (True, None) else "*"
    alias = f"\n{ALIASED}" if row.get("aliased") else ""
    return regime, (f"k = {row.get('mode')}{star}\n{row.get('celerity_m_s', math.nan):+.0f} m/s"
                    f"{alias}")


def _fixed_subtitle(sc: Scene, swept: Iterable[str]) -> str:
    """The scene parameters that no cell of the sweep changes (a swept key is never named)."""
    swept = set(swept)
    damping = (f"Kelvin–Voigt τ = {1e6 * sc.damping.tau:.3g} µs" if sc.damping.enabled
               else "no damping")
    items = (("loading.omega", f"Ω = {sc.loading.omega:g} rad/s"),
             ("geometry.delta", f"δ = {sc.geometry.delta:g}"),
             ("loading.f", f"f = {sc.loading.f:g}"),
             ("mesh.n_inner", f"N = {sc.mesh.n_inner}"),
             ("time.beta2", f"β₂ = {sc.time.beta2:g}"),
             ("damping", damping),
             ("initial.mode", f"seed mode {sc.initial.mode}"),
             ("time.end_time", f"t_end = {sc.time.end_time:g} s"))
    return ", ".join(text for key, text in items
                     if not any(k == key or k.startswith(key + ".") for k in swept))


@dataclass(frozen=True)
class _Grid:
    """The cells of one map: swept values, their positions on the axes and the cell edges."""

    xs: list
    ys: list
    xpos: list
    ypos: list
    xe: list
    ye: list
    xscale: str
    yscale: str
    numeric: bool


def _grid(sel: list[dict], distinct: dict, xkey: str, ykey: str | None, mp: dict) -> _Grid:
    """The grid of the rows ``sel``: numeric axes at their values (log where they span 20x),
    other axes at 0, 1, 2 ... with their values as tick labels."""
    import numpy as np

    xs = [v for v in distinct[xkey] if any(_hashable(r[xkey]) == v for r in sel)]
    ys = ([v for v in distinct[ykey] if any(_hashable(r[ykey]) == v for r in sel)]
          if ykey else [0.0])
    numeric = _numeric(xs) and _numeric(ys)
    xscale = _axis_scale(xs, mp.get("xscale", "auto")) if numeric else "linear"
    yscale = _axis_scale(ys, mp.get("yscale", "auto")) if numeric and ykey else "linear"
    xpos = xs if numeric else list(range(len(xs)))
    ypos = ys if numeric else list(range(len(ys)))
    xe = _edges(xpos, xscale) if numeric else list(np.arange(len(xs) + 1) - 0.5)
    ye = _edges(ypos, yscale) if numeric and ykey else list(np.arange(len(ys) + 1) - 0.5)
    return _Grid(xs, ys, xpos, ypos, xe, ye, xscale, yscale, numeric)


def _draw_cells(ax, grid: _Grid, cells: list[tuple], cmap, norm,  # noqa: ANN001
                face: dict | None = None):  # noqa: ANN202 - the QuadMesh
    """Colour and label the cells: ``cells`` = (i, j, value, text, dark) with value the
    colour index (NaN: white); ``face`` maps a value to the label's box colour (white
    otherwise); dark cells get white text."""
    import numpy as np

    values = np.full((len(grid.ys), len(grid.xs)), np.nan)
    for i, j, value, text, dark in cells:
        values[i, j] = np.nan if value is None else value
        ax.text(grid.xpos[j], grid.ypos[i], text, ha="center", va="center", fontsize=7,
                color="white" if dark else "black",
                bbox={"boxstyle": "round,pad=0.2", "ec": "none", "alpha": 0.9,
                      "fc": (face or {}).get(value, "white")})
    mesh = ax.pcolormesh(grid.xe, grid.ye, np.ma.masked_invalid(values), cmap=cmap,
                         norm=norm, edgecolors="white", linewidth=0.8)
    ax.set_xscale(grid.xscale)
    ax.set_yscale(grid.yscale)
    ax.minorticks_off()
    ax.set_xticks(grid.xpos, [_fmt(v) for v in grid.xs])
    ax.set_yticks(grid.ypos, [_fmt(v) for v in grid.ys])
    return mesh


#: How a member's direction reads in a map cell: the celerity's sign, + = rotation sense.
DIRECTION_SIGN = {"rotation": "+", "opposite": "−"}


def census_cells(meta: dict) -> list[dict]:
    """What the regime map draws at each point of ``meta`` (``attractors_map.json``).

    Per point: its swept values; the dominant member (``dominant``, with ``k``, ``direction``,
    ``regime``, ``class`` and its share with the Wilson interval); the number of attractors
    (settled members); P(stick-slip-separation) with its Wilson interval; ``modes``, the k each
    start reached (for the reduced model's boundaries); and the cell's colour category
    (the dominant member's regime, or its class where it has none: steady sliding, diverged,
    failed), its ``text`` and the ``p_text`` of the P(SSS) panel.
    """
    cells = []
    for p in meta["points"]:
        table = p.get("table") or []
        top = next((m for m in table if m["member"] == p["dominant"]), None)
        cell = {key: p[key] for key in meta["keys"]}
        cell.update(point=p["point"], dominant=p["dominant"], attractors=p["attractors"],
                    starts=p["starts"], finished=p["finished"],
                    share=p["dominant_share"], share_lo=p["dominant_lo"],
                    share_hi=p["dominant_hi"], p_sss=p["p_sss"], p_sss_lo=p["p_sss_lo"],
                    p_sss_hi=p["p_sss_hi"],
                    modes=[m["k"] for m in table if m["k"] for _ in range(m["count"])])
        cell.update({key: top[key] if top else None
                     for key in ("k", "direction", "regime", "class")})
        cell["category"] = (top["regime"] if top["k"] else top["class"]) if top else None
        cell["text"] = _cell_text(cell)
        cell["p_text"] = ("no start\nfinished" if p["p_sss"] is None else
                          f"{100 * p['p_sss']:.0f} %\n[{100 * p['p_sss_lo']:.0f}, "
                          f"{100 * p['p_sss_hi']:.0f}]")
        cells.append(cell)
    return cells


def _cell_text(cell: dict) -> str:
    """"k = 11 −\n58 % of 16\n2 attractors": the dominant member (k and the celerity's
    sign, + = rotation; "multi" for a multi-wave attractor, "unsettled" for a cycle still
    settling),
    its share of the finished starts, and the number of attractors."""
    if cell["dominant"] is None:
        return f"pending\n0 of {cell['starts']}"
    if cell["k"]:
        tag = {"wave": "", "multi-wave": " multi"}.get(cell["class"], f" {cell['class']}")
        what = f"k = {cell['k']} {DIRECTION_SIGN.get(cell['direction'], '?')}{tag}"
    else:
        what = {"steady-sliding": "steady sliding", "failed": "error"}.get(cell["class"],
                                                                           cell["class"])
    plural = "" if cell["attractors"] == 1 else "s"
    return (f"{what}\n{100 * cell['share']:.0f} % of {cell['finished']}\n"
            f"{cell['attractors']} attractor{plural}")


def _map_rows(sweep_dir: Path, meta: dict) -> tuple[list[dict], list[str], dict | None]:
    """(rows, swept keys, census map) of a sweep directory: one row per run, or, for a sweep
    with an ``[attractors]`` table, one per grid point (``studies.attractors.maps``). Every
    row carries its cell's ``category``, ``text`` and the ``modes`` its runs found (one k per
    run)."""
    census = _read_json(sweep_dir / "attractors_map.json")
    if census is not None:
        return census_cells(census), list(census["keys"]), census
    rows = []
    for r in meta["rows"]:
        category, text = cell_label(r)
        wave = category not in (None, "steady-sliding", "diverged", "failed")
        modes = [int(r["mode"])] if wave and r.get("mode") is not None else []
        rows.append({**r, "category": category, "text": text, "modes": modes})
    return rows, list(meta["parameters"]), None


def plot_sweep(sweep_dir: str | Path) -> list[Path]:
    """Regime map(s) of a sweep directory: ``regime_map[_<other params>].png``.

    One map per combination of the swept parameters that are not on the axes. Cells are
    coloured by the FE regime, annotated with the mode k and the celerity (m/s, + = rotation
    sense); lines mark the semi-analytical existence boundary of stick-slip (solid) and
    stick-slip-separation (dashed) waves for the wavenumbers of ``map.k`` (default: the
    four modes that most FE runs selected). A sweep with an ``[attractors]`` table (a census
    at every point) draws its census instead (``census_cells``):
    each cell coloured by its dominant member's regime, with the member's k and direction,
    its share and the number of attractors; a second panel gives P(stick-slip-separation)
    with its 95 % Wilson interval.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sweep_dir = Path(sweep_dir)
    meta = read_table(sweep_dir)
    rows, params, census = _map_rows(sweep_dir, meta)
    distinct = {k: sorted({_hashable(r[k]) for r in rows if r.get(k) is not None}, key=_sortkey)
                for k in params}
    varying = [k for k in params if len(distinct[k]) > 1]
    mp = meta.get("map") or {}
    xkey = mp.get("x") or (varying[0] if varying else (params[0] if params else None))
    ykey = mp.get("y") or next((k for k in varying if k != xkey), None)
    if xkey is None:
        raise SweepError(f"{sweep_dir}: nothing was swept; no map to draw")
    others = [k for k in varying if k not in (xkey, ykey)]
    base = _map_base(sweep_dir, meta)
    outputs = []
    for combo in list(itertools.product(*(distinct[k] for k in others))) or [()]:
        fixed = dict(zip(others, combo, strict=True))
        sel = [r for r in rows if all(_hashable(r.get(k)) == v for k, v in fixed.items())
               and r.get(xkey) is not None and (ykey is None or r.get(ykey) is not None)]
        grid = _grid(sel, distinct, xkey, ykey, mp)
        panels = 2 if census else 1
        fig, axes = plt.subplots(1, panels, squeeze=False, figsize=(
            panels * (2.0 + 1.15 * len(grid.xs)) + (1.2 if census else 0.0),
            1.9 + 0.75 * len(grid.ys)), layout="constrained" if census else None)
        axes = list(axes[0])
        cells = [(grid.ys.index(_hashable(r[ykey])) if ykey else 0,
                  grid.xs.index(_hashable(r[xkey])), r) for r in sel]
        handles = _draw_regimes(axes[0], grid, cells)
        if census:
            _draw_probability(fig, axes[1], grid, cells)
        for ax in axes:
            ax.set_xlabel(_label(xkey))
            if not ykey:
                ax.set_yticks([])
        axes[0].set_ylabel(_label(ykey) if ykey else "")
        note = ""
        reached = Counter(k for r in sel for k in r["modes"])  # runs (starts) per mode
        ks = tuple(mp.get("k") or sorted(k for k, _ in reached.most_common(4)))
        if (mp.get("semianalytic", True) and grid.numeric and ykey and ks
                and (xkey in _SEMIANALYTIC_KEYS or ykey in _SEMIANALYTIC_KEYS)):
            sa = _semianalytic_overlay(sweep_dir, meta, base, xkey, list(grid.xs),
                                       grid.xscale, ykey, list(grid.ys), grid.yscale, fixed,
                                       ks)
            handles += [_draw_boundaries(ax, sa, ks) for ax in axes][0]
            note = f"; boundaries: reduced model, junction {'/'.join(sa['junctions'])}"
        fixed_txt = ", ".join(f"{_label(k)} = {_fmt(v)}" for k, v in fixed.items())
        sc = base.with_overrides(*(f"{k}={_toml_value(v)}" for k, v in fixed.items()))
        stars = any(r["text"].split("\n")[0].endswith("*") for r in sel)
        alias = any(r["text"].endswith(f"\n{ALIASED}") for r in sel)
        unswept = _fixed_subtitle(sc, [*params, *(["initial.mode"] if census else [])])
        what = (f"census of {census['attractors'].get('starts')} random starts at every point"
                if census else "FE regime, k and celerity (m/s, + = rotation)")
        title = (f"sweep {meta['name']}: {what}" + (f"\nthis map: {fixed_txt}" if fixed_txt
                                                    else "")
                 + f"\n{unswept}{note}"
                 + ("\n* no limit cycle by t_end (transient)" if stars else "")
                 + (f"\n{ALIASED}: the samples alias the wave, so k and c are not the run's "
                    "(sweep.csv's message: the output.sample_interval that resolves it)"
                    if alias else ""))
        _annotate(fig, axes, title, handles, bool(census), len(grid.ys))
        suffix = "".join(f"_{k.rsplit('.', 1)[-1]}-{_slug_value(v)}" for k, v in fixed.items())
        outputs.append(_save(fig, sweep_dir / f"regime_map{suffix}.png"))
    return outputs


#: The colour categories of a map cell, in legend order.
MAP_CATEGORIES = (*REGIMES, "failed")


def _draw_regimes(ax, grid: _Grid, cells: list[tuple]) -> list:  # noqa: ANN001
    """The regime panel: cells coloured by ``category``, labelled with ``text``; returns the
    legend entries of the categories shown."""
    import numpy as np
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    cmap = ListedColormap([REGIME_COLORS[c] for c in MAP_CATEGORIES])
    cmap.set_bad("white")
    norm = BoundaryNorm(np.arange(len(MAP_CATEGORIES) + 1) - 0.5, cmap.N)
    index = {c: n for n, c in enumerate(MAP_CATEGORIES)}
    face = {n: REGIME_COLORS[c] for c, n in index.items()}
    _draw_cells(ax, grid, [(i, j, index.get(r["category"]), r["text"],
                            r["category"] in ("diverged", "stick-slip-separation"))
                           for i, j, r in cells], cmap, norm, face)
    shown = {r["category"] for _, _, r in cells}
    return [Patch(facecolor=REGIME_COLORS[c], edgecolor="0.5", label=c)
            for c in MAP_CATEGORIES if c in shown]


def _draw_probability(fig, ax, grid: _Grid, cells: list[tuple]) -> None:  # noqa: ANN001
    """The census's second panel: P(stick-slip-separation) per cell, with its 95 % Wilson
    interval as the cell's text."""
    from matplotlib.colors import Normalize

    mesh = _draw_cells(ax, grid, [(i, j, r["p_sss"], r["p_text"], False)
                                  for i, j, r in cells], "Reds", Normalize(0.0, 1.0))
    fig.colorbar(mesh, ax=ax, label="P(stick-slip-separation)")
    ax.set_title("P(stick-slip-separation) of the random starts\n[95 % Wilson interval]",
                 fontsize=8)


def _annotate(fig, axes: list, title: str, handles: list, census: bool,  # noqa: ANN001
              n_rows: int) -> None:
    """Title and legend: over and under the map; for a census, over and under both panels,
    each panel with its own title."""
    if not census:
        axes[0].set_title(title, fontsize=8)
        axes[0].legend(handles=handles, fontsize=7, loc="upper center", frameon=False,
                       ncol=2, bbox_to_anchor=(0.5, -0.13 if n_rows > 3 else -0.25))
        return
    fig.suptitle(title, fontsize=8)
    axes[0].set_title("dominant member: k (+ = with the rotation), its share of the finished "
                      "starts,\nnumber of attractors (rigid waves)", fontsize=8)
    fig.legend(handles=handles, fontsize=7, loc="outside lower center", frameon=False, ncol=2)


def _save(fig, path: Path) -> Path:  # noqa: ANN001
    """Write ``fig`` to ``path`` through a temporary file: a reader never sees half a PNG."""
    import matplotlib.pyplot as plt

    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=130, bbox_inches="tight")
    plt.close(fig)
    tmp.replace(path)
    return path


def _draw_boundaries(ax, sa: dict, ks: tuple[int, ...]) -> list:  # noqa: ANN001
    """Hatch where the reduced model has an admissible wave (``_semianalytic_overlay``),
    outline its boundary; returns the legend entries (also for a wave found nowhere)."""
    import numpy as np
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = []
    kset = ", ".join(map(str, ks))
    for name, style, hatch, what in (("stick-slip", "-", "//", "solid"),
                                     ("stick-slip-separation", "--", "\\\\", "dashed")):
        g = sa[name]
        z = np.asarray(g["admissible"], dtype=float)
        if not z.any():
            handles.append(Line2D([], [], color="0.6", linestyle=style,
                                  label=f"no admissible semi-analytical {name} wave "
                                        f"on this grid (k ∈ {{{kset}}})"))
            continue
        if not z.all():
            ax.contour(g["x"], g["y"], z, levels=[0.5], colors="k", linestyles=style,
                       linewidths=1.8)
        ax.contourf(g["x"], g["y"], z, levels=[0.5, 1.5], colors="none", hatches=[hatch])
        handles.append(Patch(facecolor="none", edgecolor="k", hatch=hatch, linestyle=style,
                             label=f"semi-analytical {name} wave exists "
                                   f"(k ∈ {{{kset}}}; {what} boundary)"))
    return handles


def _map_base(sweep_dir: Path, meta: dict) -> Scene:
    """A resolved scene of the sweep (every swept key is overridden per cell anyway).

    A run's own ``scene.toml`` first, so a sweep directory copied elsewhere (out of a
    container) still plots; one that no longer loads (damaged, edited) is passed over; the
    base scene file the sweep named otherwise (ReadError, one line, where none loads).
    """
    for row in meta["rows"]:
        path = sweep_dir / str(row.get("run_dir", "")) / "scene.toml"
        if row.get("run_dir") and path.is_file():
            try:
                return load_scene(path)
            except SceneError:
                continue
    try:
        return load_scene(meta["base"], meta.get("set", []))
    except SceneError as err:
        raise ReadError(sweep_dir / "sweep.json", f"no run's scene.toml loads, nor its base "
                        f"scene ({' '.join(str(err).split())[:160]})",
                        "run the sweep again, or restore its base scene file") from None


def _hashable(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


def _fmt(v: Any) -> str:
    """A swept value as a tick or title label (numbers %g, booleans and strings as in TOML)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return f"{v:g}"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def _sortkey(v: Any) -> tuple:
    return (0, float(v), "") if _numeric([v]) else (1, 0.0, str(v))


_LABELS = {"loading.omega": "Ω (rad/s)", "geometry.delta": "δ = d/R", "loading.f": "f",
           "mesh.n_inner": "N (contact nodes)", "initial.seed": "seed",
           "initial.mode": "initial mode", "geometry.xi": "ξ = R*/R"}


def _label(key: str | None) -> str:
    return _LABELS.get(key or "", key or "")


