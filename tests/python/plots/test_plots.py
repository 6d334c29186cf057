"""Tests of vadsim.plots (python/vadsim/plots/: flow, maps, design, traces, campaigns, style).

Most figures are drawn from small synthetic datasets with the schema of vadsim.studies.sweep (dims
(*design_axes, "flow_gpm"), coordinate f_exc_hz along flow, one variable per sweep.FEATURES);
only time_traces needs a real (tiny) run. Each test saves its figure as PNG into tmp_path and
checks the figure's structure: number of axes, units in the axis labels, the regime legend,
the plotted data against its source, and that bad input raises ValueError naming the problem.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest
import vadsim
import xarray as xr
from matplotlib.collections import LineCollection, PathCollection, QuadMesh
from matplotlib.colors import is_color_like, to_hex
from matplotlib.figure import Figure
from matplotlib.image import AxesImage
from matplotlib.legend import Legend
from matplotlib.text import Text
from vadsim import plots
from vadsim.plots.style import edges as cell_edges
from vadsim.plots.style import feature_label
from vadsim.signals.features import Feature
from vadsim.signals.labels import regime_name
from vadsim.studies.sweep import FEATURES

ALPHA = 0.67  # 7in tool: f = alpha Q / (2 pi)
M_REF = 17.79  # kg, the 7in preset's reference mass
FLOWS = np.array([200.0, 250, 300, 350, 400, 450, 500, 550, 600, 650])
SCEN = np.array([1, 1, 1, 3, 3, 4, 4, 5, 5, -1])
FIELD_CSV = Path(vadsim.__file__).parent / "data" / "thesis" / "field_events.csv"


# --------------------------------------------------------------------------------------------
# Synthetic datasets
# --------------------------------------------------------------------------------------------


def _features(scen: np.ndarray, j: np.ndarray, flows: np.ndarray) -> dict[str, np.ndarray]:
    """Every sweep feature for an array of scenario codes (NaN where a run failed)."""
    scen = np.asarray(scen)
    failed = scen == -1
    z_spring = np.select([np.isin(scen, [1, 6, 7]), np.isin(scen, [2, 3])], [1.0, 0.5], 0.0)
    z_impact = np.select([np.isin(scen, [1, 2, 5]), np.isin(scen, [3, 4, 6])], [1.0, 2 / 3],
                         0.0)
    peak = 20 + 0.1 * (flows - 150) + 0 * scen
    out = {
        "z_spring": z_spring,
        "z_impact": z_impact,
        "z_off_bottom": np.zeros(scen.shape),
        "z_on_bottom": np.where(scen == 5, 0.25, 0.0),
        "z_rock": np.zeros(scen.shape),
        "scenario": scen.astype(np.int64),
        "j_mean": 0.9 * j,
        "j_pos": j,
        "j_pos_kN": j * M_REF / 1000,
        "x1_peak_mean_g": peak,
        "x1_peak_std_g": 0.1 * peak,
        "x5_peak_mean_g": 0.5 * peak,
        "x5_peak_std_g": 0.05 * peak,
        "x1_impact_hz": ALPHA * flows / (2 * math.pi) + 0 * scen,
        "period": np.ones(scen.shape, np.int64),
        "periodicity": np.full(scen.shape, "period-1", dtype=object),
        "steps": np.full(scen.shape, 1000, np.int64),
        "steady_period": np.ones(scen.shape, np.int64),
        "error": np.where(failed, "CVODE failed", ""),
    }
    for name in out:
        if out[name].dtype.kind == "f":
            out[name] = np.where(failed, np.nan, out[name])
    return out


def _dataset(dims: tuple[str, ...], coords: dict[str, np.ndarray], scen: np.ndarray,
             j: np.ndarray, m_ref: float | None = M_REF, preset: str = "7in-cde") -> xr.Dataset:
    flows = coords["flow_gpm"]
    data = _features(scen, j, np.broadcast_to(flows, np.shape(scen)))
    assert set(data) == set(FEATURES)
    ds = xr.Dataset(
        {name: (dims, data[name]) for name in FEATURES},
        coords={**coords, "f_exc_hz": ("flow_gpm", ALPHA * flows / (2 * math.pi))},
    )
    ds.attrs.update(preset=preset, mode="independent", cycles=400.0, analyse_cycles=200.0,
                    wob_klbf=20.0)
    if m_ref is not None:
        ds.attrs["m_ref_kg"] = m_ref
    return ds


def flow_dataset(scen: np.ndarray = SCEN, j: np.ndarray | None = None, flows: np.ndarray = FLOWS,
                 **kw) -> xr.Dataset:
    if j is None:
        j = np.array([100.0, 130, 160, 45, 40, 25, 23, 23, 22, np.nan])
    return _dataset(("flow_gpm",), {"flow_gpm": flows}, scen, j, **kw)


KS = np.array([1.0e5, 2.5e5, 4.0e5, 5.5e5])
FLOWS_MAP = np.array([200.0, 250, 300, 350, 400, 500])
SCEN_MAP = np.array([
    [1, 1, 2, 3, 4, 5],
    [1, 1, 1, 3, 4, 5],
    [1, 1, 1, 3, 3, 5],
    [1, 1, 1, 1, 3, -1],
])
J_MAP = np.array([
    [80.0, 100, 120, 40, 30, 20],
    [90.0, 120, 150, 45, 30, 20],
    [95.0, 130, 160, 150, 35, 22],
    [95.0, 130, 145, 120, 35, np.nan],
])


def map_dataset(**kw) -> xr.Dataset:
    return _dataset(("kS", "flow_gpm"), {"kS": KS, "flow_gpm": FLOWS_MAP}, SCEN_MAP, J_MAP, **kw)


def map3_dataset() -> xr.Dataset:
    """Two design dims (kS, Fo) besides flow."""
    fo = np.array([300.47, 400.0])
    scen = np.stack([SCEN_MAP, SCEN_MAP], axis=1)
    j = np.stack([J_MAP, 1.2 * J_MAP], axis=1)
    return _dataset(("kS", "Fo", "flow_gpm"), {"kS": KS, "Fo": fo, "flow_gpm": FLOWS_MAP},
                    scen, j)


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def saved(fig: Figure, path: Path) -> None:
    assert isinstance(fig, Figure)
    assert path.exists() and path.stat().st_size > 1000, path


def legend_texts(ax) -> list[str]:
    """Texts of every legend drawn on ax (including legends kept with add_artist)."""
    legends = [c for c in ax.get_children() if isinstance(c, Legend)]
    return [t.get_text() for leg in legends for t in leg.get_texts()]


def legend_titles(ax) -> list[str]:
    legends = [c for c in ax.get_children() if isinstance(c, Legend)]
    return [leg.get_title().get_text() for leg in legends]


def line_by_label(ax, label: str):
    lines = [ln for ln in ax.get_lines() if ln.get_label() == label]
    assert len(lines) == 1, [ln.get_label() for ln in ax.get_lines()]
    return lines[0]


def regime_entries(codes) -> set[str]:
    return {plots.regime_label(c) for c in np.unique(codes)}


# --------------------------------------------------------------------------------------------
# Module constants
# --------------------------------------------------------------------------------------------


def test_regime_colors_cover_every_code_with_distinct_colours():
    assert set(plots.REGIME_COLORS) == set(range(-1, 8))
    assert all(is_color_like(c) for c in plots.REGIME_COLORS.values())
    assert len({to_hex(c) for c in plots.REGIME_COLORS.values()}) == 9


def test_regime_label_names_the_scenario():
    assert plots.regime_label(1) == f"1: {regime_name(1)}"
    assert plots.regime_label(-1) == "failed run"
    with pytest.raises(ValueError, match="scenario"):
        plots.regime_label(12)


# --------------------------------------------------------------------------------------------
# peaks_vs_flow
# --------------------------------------------------------------------------------------------


def test_peaks_vs_flow_plots_mean_and_dispersion(tmp_path):
    ds = flow_dataset()
    fig = plots.peaks_vs_flow(ds, path=tmp_path / "peaks.png")
    saved(fig, tmp_path / "peaks.png")
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert "(gal/min)" in ax.get_xlabel()
    assert "(g)" in ax.get_ylabel()
    assert "7in-cde" in ax.get_title() and "independent" in ax.get_title()
    (container,) = ax.containers
    data_line = container.lines[0]
    np.testing.assert_array_equal(data_line.get_xdata(), FLOWS)
    np.testing.assert_array_equal(data_line.get_ydata(), ds.x1_peak_mean_g.values)
    # The failed point (scenario -1) is marked.
    assert np.asarray(line_by_label(ax, "failed run").get_xdata()).tolist() == [650.0]
    # The error bar says what it is; the title carries the WOB and the length of the runs.
    assert "simulated (vadsim): mean \u00b1 std of 200 ms peaks" in legend_texts(ax)
    assert "WOB 20 klbf" in ax.get_title()
    assert "independent runs of 400 cycles (last 200 analysed)" in ax.get_title()


def test_peaks_vs_flow_x5_sensor(tmp_path):
    ds = flow_dataset()
    fig = plots.peaks_vs_flow(ds, sensor="x5", path=tmp_path / "peaks_x5.png")
    saved(fig, tmp_path / "peaks_x5.png")
    ax = fig.axes[0]
    assert ax.get_ylabel().startswith("x5")
    np.testing.assert_array_equal(ax.containers[0].lines[0].get_ydata(), ds.x5_peak_mean_g)


@pytest.mark.parametrize(
    ("key", "tool", "bit", "preset"),
    [("thesis-7in-cde", "7in", "CDE", "7in-cde"), ("thesis-7in-rc", "7in", "RC", "7in-rc"),
     ("thesis-9.5in-pdc", "9.5in", "PDC", "9.5in-pdc")],
)
def test_peaks_vs_flow_thesis_reference_plots_the_published_points(tmp_path, key, tool, bit,
                                                                   preset):
    table = pd.read_csv(FIELD_CSV)
    rows = table[(table.tool == tool) & (table.bit == bit)].sort_values("flow_gpm")
    assert len(rows) > 0
    ds = flow_dataset(preset=preset)
    fig = plots.peaks_vs_flow(ds, reference=key, path=tmp_path / f"{key}.png")
    saved(fig, tmp_path / f"{key}.png")
    ax = fig.axes[0]
    field = line_by_label(ax, "field (dissertation)")
    np.testing.assert_array_equal(field.get_xdata(), rows.flow_gpm.to_numpy(float))
    np.testing.assert_array_equal(field.get_ydata(), rows.field_peak_g.to_numpy(float))
    sim = line_by_label(ax, "simulated (dissertation)")
    np.testing.assert_array_equal(sim.get_xdata(), rows.flow_gpm.to_numpy(float))
    np.testing.assert_array_equal(sim.get_ydata(), rows.sim_peak_g.to_numpy(float))
    texts = legend_texts(ax)
    assert "field (dissertation)" in texts and "simulated (dissertation)" in texts


def test_peaks_vs_flow_reference_of_another_tool_warns():
    with pytest.warns(UserWarning, match="9.5in"):
        plots.peaks_vs_flow(flow_dataset(), reference="thesis-9.5in-pdc")


def test_peaks_vs_flow_dataframe_reference(tmp_path):
    ref = pd.DataFrame({"flow_gpm": [300.0, 200.0], "x1_peak_mean_g": [50.0, 40.0],
                        "x1_peak_std_g": [5.0, 4.0]})
    fig = plots.peaks_vs_flow(flow_dataset(), reference=ref, path=tmp_path / "df_ref.png")
    saved(fig, tmp_path / "df_ref.png")
    ax = fig.axes[0]
    (container,) = [c for c in ax.containers if c.get_label() == "reference"]
    np.testing.assert_array_equal(container.lines[0].get_xdata(), [200.0, 300.0])
    np.testing.assert_array_equal(container.lines[0].get_ydata(), [40.0, 50.0])
    # The field table itself (rows selected by the caller) works as a DataFrame reference.
    table = pd.read_csv(FIELD_CSV)
    rc = table[(table.tool == "7in") & (table.bit == "RC")]
    fig = plots.peaks_vs_flow(flow_dataset(), reference=rc)
    line = line_by_label(fig.axes[0], "field (reference)")
    np.testing.assert_array_equal(line.get_ydata(), rc.sort_values("flow_gpm").field_peak_g)


def test_peaks_vs_flow_bad_input():
    ds = flow_dataset()
    with pytest.raises(ValueError, match="thesis-7in-cde"):
        plots.peaks_vs_flow(ds, reference="thesis-12in")
    with pytest.raises(ValueError, match="x1 only"):
        plots.peaks_vs_flow(ds, sensor="x5", reference="thesis-7in-cde")
    with pytest.raises(ValueError, match="flow_gpm"):
        plots.peaks_vs_flow(ds, reference=pd.DataFrame({"q": [1.0], "field_peak_g": [2.0]}))
    with pytest.raises(ValueError, match="field_peak_g"):
        plots.peaks_vs_flow(ds, reference=pd.DataFrame({"flow_gpm": [1.0], "g": [2.0]}))
    with pytest.raises(ValueError, match="sensor"):
        plots.peaks_vs_flow(ds, sensor="x9")
    with pytest.raises(ValueError, match="x1_peak_std_g"):
        plots.peaks_vs_flow(ds.drop_vars("x1_peak_std_g"))


# --------------------------------------------------------------------------------------------
# z_vs_flow and j_vs_flow
# --------------------------------------------------------------------------------------------


def test_z_vs_flow_draws_each_surface_on_regime_bands(tmp_path):
    ds = flow_dataset()
    fig = plots.z_vs_flow(ds, path=tmp_path / "z.png")
    saved(fig, tmp_path / "z.png")
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert "(gal/min)" in ax.get_xlabel()
    assert "(impacts/cycle)" in ax.get_ylabel()
    texts = legend_texts(ax)
    assert regime_entries(SCEN) <= set(texts)
    assert not ({plots.regime_label(c) for c in (0, 2, 6, 7)} & set(texts))
    for s in ("spring", "impact", "off_bottom", "on_bottom"):
        assert plots.SURFACE_LABELS[s] in texts
        line = line_by_label(ax, plots.SURFACE_LABELS[s])
        np.testing.assert_array_equal(line.get_ydata(), ds[f"z_{s}"].values)
    # One band per run of equal scenarios (1 1 1 | 3 3 | 4 4 | 5 5 | -1), labelled by code.
    band_labels = [t.get_text() for t in ax.texts]
    assert band_labels == ["1", "3", "4", "5", "F"]
    fig = plots.z_vs_flow(ds, surfaces=["impact", "rock"], bands=False)
    assert legend_texts(fig.axes[0]) == [plots.SURFACE_LABELS["impact"], "rock"]


def test_z_vs_flow_bad_surface():
    with pytest.raises(ValueError, match="bogus"):
        plots.z_vs_flow(flow_dataset(), surfaces=["spring", "bogus"])


def test_j_vs_flow_in_kn_coloured_by_regime(tmp_path):
    ds = flow_dataset()
    fig = plots.j_vs_flow(ds, path=tmp_path / "j.png")
    saved(fig, tmp_path / "j.png")
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert "(kN)" in ax.get_ylabel() and "(gal/min)" in ax.get_xlabel()
    assert set(legend_texts(ax)) == regime_entries(SCEN)
    for coll in ax.collections:
        code = int(coll.get_label().split(":")[0])
        sel = SCEN == code
        expected = np.c_[FLOWS[sel], ds.j_pos.values[sel] * M_REF / 1000]
        np.testing.assert_allclose(coll.get_offsets(), expected)
        assert to_hex(coll.get_facecolor()[0]) == to_hex(plots.REGIME_COLORS[code])


def test_j_vs_flow_units(tmp_path):
    ds = flow_dataset()
    fig = plots.j_vs_flow(ds, unit="N/kg", path=tmp_path / "j_nkg.png")
    saved(fig, tmp_path / "j_nkg.png")
    assert "(N/kg)" in fig.axes[0].get_ylabel()
    no_mass = flow_dataset(m_ref=None)
    assert "(N/kg)" in plots.j_vs_flow(no_mass).axes[0].get_ylabel()
    with pytest.raises(ValueError, match="m_ref_kg"):
        plots.j_vs_flow(no_mass, unit="kN")
    with pytest.raises(ValueError, match="unit"):
        plots.j_vs_flow(ds, unit="lbf")
    with pytest.raises(ValueError, match="variable"):
        plots.j_vs_flow(ds, variable="j_neg")


# --------------------------------------------------------------------------------------------
# Maps
# --------------------------------------------------------------------------------------------


def test_regime_map_colours_each_point_by_scenario(tmp_path):
    ds = map_dataset()
    fig = plots.regime_map(ds, path=tmp_path / "regime_map.png")
    saved(fig, tmp_path / "regime_map.png")
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert "(Hz)" in ax.get_xlabel()
    assert "kS" in ax.get_ylabel() and "(kN/(kg m))" in ax.get_ylabel()
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    np.testing.assert_array_equal(np.asarray(mesh.get_array()).reshape(SCEN_MAP.shape), SCEN_MAP)
    texts = legend_texts(ax)
    assert regime_entries(SCEN_MAP) <= set(texts)
    assert any("operating range" in t for t in texts)
    assert any(t.startswith("max J* = ") and t.endswith("kN") for t in texts)
    # The operating range outline exists (J* >= 0.9 * 160 N/kg at 4 cells).
    outlines = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert outlines and all(len(c.get_segments()) > 0 for c in outlines)
    # x is the excitation frequency, y the parameter in kN/(kg m).
    xmin, xmax = ax.get_xlim()
    f = ALPHA * FLOWS_MAP / (2 * math.pi)
    assert xmin < f[0] < f[-1] < xmax
    ymin, ymax = ax.get_ylim()
    assert ymin < KS[0] / 1000 < KS[-1] / 1000 < ymax


def test_regime_map_marks_the_points_an_adaptive_map_ran(tmp_path):
    ds = map_dataset()
    ran = np.zeros(SCEN_MAP.shape, bool)
    ran[::2, ::2] = True
    ds["simulated"] = (("kS", "flow_gpm"), ran)
    fig = plots.regime_map(ds, path=tmp_path / "adaptive.png")
    saved(fig, tmp_path / "adaptive.png")
    ax = fig.axes[0]
    (dots,) = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(dots.get_offsets()) == ran.sum()
    assert any(t.startswith("run (") and "the rest filled" in t for t in legend_texts(ax))
    fig = plots.regime_map(ds, show_simulated=False)
    assert not [c for c in fig.axes[0].collections if isinstance(c, PathCollection)]


def test_regime_map_without_overlay_and_param_selection(tmp_path):
    ds = map3_dataset().isel(Fo=[0])  # Fo of size 1: kS is the only varying design dim
    fig = plots.regime_map(ds, operating_range=False, path=tmp_path / "regime_map_plain.png")
    saved(fig, tmp_path / "regime_map_plain.png")
    ax = fig.axes[0]
    assert set(legend_texts(ax)) == regime_entries(SCEN_MAP)
    assert not [c for c in ax.collections if isinstance(c, LineCollection)]
    fig = plots.regime_map(map3_dataset().sel(kS=KS[0]), param="Fo")
    assert "Fo" in fig.axes[0].get_ylabel() and "(N/kg)" in fig.axes[0].get_ylabel()


def test_regime_map_bad_input():
    with pytest.raises(ValueError, match=r"(?s)design dimensions.*'kS'.*'Fo'.*param"):
        plots.regime_map(map3_dataset())
    with pytest.raises(ValueError, match="'Fo'"):
        plots.regime_map(map3_dataset(), param="kS")
    with pytest.raises(ValueError, match="bogus"):
        plots.regime_map(map_dataset(), param="bogus")
    with pytest.raises(ValueError, match="design dimension"):
        plots.regime_map(flow_dataset())
    with pytest.raises(ValueError, match="scenario"):
        plots.regime_map(map_dataset().drop_vars("scenario"))


def test_j_map_colour_bar_in_kn(tmp_path):
    ds = map_dataset()
    fig = plots.j_map(ds, path=tmp_path / "j_map.png")
    saved(fig, tmp_path / "j_map.png")
    assert len(fig.axes) == 2  # map and colour bar
    ax, cax = fig.axes
    assert "(Hz)" in ax.get_xlabel() and "(kN/(kg m))" in ax.get_ylabel()
    assert "(kN)" in cax.get_ylabel()
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    np.testing.assert_allclose(np.ma.filled(mesh.get_array(), np.nan).reshape(J_MAP.shape),
                               J_MAP * M_REF / 1000)
    texts = legend_texts(ax)
    assert any("operating range" in t for t in texts) and "failed run" in texts
    fig = plots.j_map(ds, unit="N/kg", operating_range=False, cmap="magma")
    assert "(N/kg)" in fig.axes[1].get_ylabel()


def test_j_map_operating_range_outline_matches_the_cells():
    # With a single design value the outline must enclose exactly the flows with J* >= 90 %.
    ds = map_dataset().isel(kS=[2])
    fig = plots.j_map(ds, unit="N/kg")
    ax = fig.axes[0]
    (halo, line) = [c for c in ax.collections if isinstance(c, LineCollection)]
    xs = np.concatenate([s[:, 0] for s in line.get_segments()])
    f = ALPHA * FLOWS_MAP / (2 * math.pi)
    # In range: 300 and 350 gal/min (160 and 150 >= 144); the outline spans their cells.
    edges = cell_edges(f)
    assert math.isclose(xs.min(), edges[2]) and math.isclose(xs.max(), edges[4])


# --------------------------------------------------------------------------------------------
# design_comparison
# --------------------------------------------------------------------------------------------


def test_design_comparison_marks_ranges_and_peak_ratio(tmp_path):
    flows = np.arange(200.0, 410.0, 10.0)
    # max 100 at 290; >= 90 for |q - 290| <= 22.4
    j0 = np.maximum(100 - 0.02 * (flows - 290) ** 2, 5)
    j1 = 185 - 0.005 * (flows - 340) ** 2  # max 185 at 340; >= 166.5 for |q - 340| <= 60.8
    scen = np.ones(flows.size, int)
    ds0 = flow_dataset(scen=scen, j=j0, flows=flows)
    ds1 = flow_dataset(scen=scen, j=j1, flows=flows)
    fig = plots.design_comparison(ds0, ds1, path=tmp_path / "design.png")
    saved(fig, tmp_path / "design.png")
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert "(kN)" in ax.get_ylabel() and "(gal/min)" in ax.get_xlabel()
    (title,) = legend_titles(ax)
    assert "\u00d71.85" in title and "+85 %" in title
    assert "40 \u2192 120 gal/min" in title and "+200 %" in title
    texts = legend_texts(ax)
    assert "original: operating range 270\u2013310 gal/min" in texts
    assert "recommended: operating range 280\u2013400 gal/min" in texts
    np.testing.assert_allclose(line_by_label(ax, "recommended").get_ydata(), j1 * M_REF / 1000)


def test_design_comparison_bad_input():
    with pytest.raises(ValueError, match="flow_gpm"):
        plots.design_comparison(flow_dataset(), flow_dataset().rename(flow_gpm="q"))
    with pytest.raises(ValueError, match="labels"):
        plots.design_comparison(flow_dataset(), flow_dataset(), labels=("a", "b", "c"))


# --------------------------------------------------------------------------------------------
# time_traces (one tiny real run)
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def run(tiny_run):
    return tiny_run


def test_time_traces_three_panels(tmp_path, run):
    fig = plots.time_traces(run, cycles=3, path=tmp_path / "traces.png")
    saved(fig, tmp_path / "traces.png")
    assert len(fig.axes) == 3
    ax_f, ax_d, ax_a = fig.axes
    assert "(kN)" in ax_f.get_ylabel()
    assert "(mm)" in ax_d.get_ylabel()
    assert "(g)" in ax_a.get_ylabel()
    assert "(s)" in ax_a.get_xlabel()
    t0, t1 = ax_a.get_xlim()
    assert math.isclose(t1 - t0, 3 / run.f_exc_hz, rel_tol=0.01)
    # Indentations from MODEL.md geometry, in mm.
    sel = run.t >= t0 - 1e-12
    d_impact = 1e3 * (run.x[sel, 1] - run.x[sel, 0])
    line = [ln for ln in ax_d.get_lines() if ln.get_label().startswith("$d_I$")][0]
    np.testing.assert_allclose(line.get_ydata(), d_impact)
    p = run.params
    d_spring = 1e3 * ((run.x[sel, 2] + p["LS"] * p["l0"]) - (run.x[sel, 1] - p["L2"] * p["l0"]))
    line = [ln for ln in ax_d.get_lines() if ln.get_label().startswith("$d_S$")][0]
    np.testing.assert_allclose(line.get_ydata(), d_spring)
    # Forces in kN: F_I = contact_forces[:, 1] * m* / 1000.
    line = [ln for ln in ax_f.get_lines() if ln.get_label().startswith("$F_{I}$")][0]
    np.testing.assert_allclose(line.get_ydata(), run.contact_forces[sel, 1] * run.m_ref_kg / 1e3)
    # One dotted vertical line per contact onset in the span, in every panel.
    ev = run.events
    n_onsets = int(((ev.kind == "onset") & ev.surface.isin(["spring", "impact"])
                    & (ev.time_s >= t0) & (ev.time_s <= t1)).sum())
    assert n_onsets >= 4
    for ax in fig.axes:
        assert sum(ln.get_linestyle() == ":" for ln in ax.get_lines()) == n_onsets
    assert "#2 impact face onset" in legend_texts(ax_a)
    assert "200 gal/min" in fig.get_suptitle() and "7in-cde" in fig.get_suptitle()
    assert "run of 20 cycles (last 10 analysed)" in fig.get_suptitle()


def test_time_traces_bad_input(run):
    empty = vadsim.simulate("7in-cde", 200, cycles=4, analyse_cycles=2, record="none",
                            summary_rate_hz=2000)
    with pytest.raises(ValueError, match="record='window'"):
        plots.time_traces(empty)
    with pytest.raises(ValueError, match="cycles"):
        plots.time_traces(run, cycles=0)
    fig = plots.time_traces(run, cycles=50, unit="N/kg")  # more cycles than recorded: all
    assert "(N/kg)" in fig.axes[0].get_ylabel()
    assert math.isclose(fig.axes[2].get_xlim()[0], run.t[0])


# --------------------------------------------------------------------------------------------
# mismatch_heatmap
# --------------------------------------------------------------------------------------------


def test_mismatch_heatmap_centred_and_annotated(tmp_path):
    table = pd.DataFrame(
        [[0.5, -2.5, np.nan], [1.0, 0.0, 3.0]],
        index=pd.Index(["event 1", "event 2"], name="event"),
        columns=["x1_peak_mean_g", "x1_peak_std_g", "x1_impact_hz"],
    )
    fig = plots.mismatch_heatmap(table, path=tmp_path / "heatmap.png")
    saved(fig, tmp_path / "heatmap.png")
    assert len(fig.axes) == 2
    ax, cax = fig.axes
    (image,) = [c for c in ax.get_children() if isinstance(c, AxesImage)]
    assert image.norm.vmin == -3.0 and image.norm.vmax == 3.0
    assert [t.get_text() for t in ax.texts] == ["+0.5", "-2.5", "n/a", "+1.0", "+0.0", "+3.0"]
    assert [t.get_text() for t in ax.get_xticklabels()] == list(table.columns)
    assert [t.get_text() for t in ax.get_yticklabels()] == list(table.index)
    assert "(\u03c3)" in cax.get_ylabel()
    fig = plots.mismatch_heatmap(table * 0.1, annotate=False)
    assert len(fig.axes[0].texts) == 0 and fig.axes[0].get_images()[0].norm.vmax == 1.0


def test_mismatch_heatmap_bad_input():
    with pytest.raises(ValueError, match="'label'"):
        plots.mismatch_heatmap(pd.DataFrame({"a": [1.0], "label": ["x"]}))
    with pytest.raises(ValueError, match="empty"):
        plots.mismatch_heatmap(pd.DataFrame())
    with pytest.raises(ValueError, match="DataFrame"):
        plots.mismatch_heatmap(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="vmax"):
        plots.mismatch_heatmap(pd.DataFrame({"a": [1.0]}), vmax=-1)


# --------------------------------------------------------------------------------------------
# Common behaviour
# --------------------------------------------------------------------------------------------

DATASET_FUNCTIONS = [plots.peaks_vs_flow, plots.z_vs_flow, plots.j_vs_flow, plots.regime_map,
                     plots.j_map]


@pytest.mark.parametrize("func", DATASET_FUNCTIONS, ids=lambda f: f.__name__)
def test_dataset_without_flow_dimension_is_refused(func):
    ds = flow_dataset().rename(flow_gpm="q")
    with pytest.raises(ValueError, match="no 'flow_gpm' dimension"):
        func(ds)
    with pytest.raises(ValueError, match="xarray.Dataset"):
        func(ds.to_dataframe())


@pytest.mark.parametrize("func", [plots.peaks_vs_flow, plots.z_vs_flow, plots.j_vs_flow],
                         ids=lambda f: f.__name__)
def test_flow_plots_refuse_a_map_but_accept_one_row(func, tmp_path):
    with pytest.raises(ValueError, match=r"\['kS'\].*ds.isel\(kS=0\)"):
        func(map_dataset())
    fig = func(map_dataset().isel(kS=[1]), path=tmp_path / f"{func.__name__}_row.png")
    saved(fig, tmp_path / f"{func.__name__}_row.png")
    assert "kS = 2.5e+05" in fig.axes[0].get_title()


def test_save_formats_and_bad_suffix(tmp_path):
    ds = flow_dataset()
    for suffix in ("pdf", "svg"):
        path = tmp_path / "sub" / f"j.{suffix}"
        plots.j_vs_flow(ds, path=path)
        assert path.stat().st_size > 1000
    with pytest.raises(ValueError, match=r"\.png, \.pdf, \.svg"):
        plots.j_vs_flow(ds, path=tmp_path / "j.jpg")


def test_draws_into_a_given_axes_without_pyplot():
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    font = mpl.rcParams["font.size"]
    fig = Figure(figsize=(12, 4), layout="constrained")
    axes = fig.subplots(1, 3)
    assert plots.j_vs_flow(flow_dataset(), ax=axes[0]) is fig
    assert plots.z_vs_flow(flow_dataset(), ax=axes[1]) is fig
    assert plots.mismatch_heatmap(pd.DataFrame({"a": [1.0, -1.0]}), ax=axes[2]) is fig
    assert axes[0].get_ylabel() == "J* (kN)" and "Z*" in axes[1].get_ylabel()
    assert plt.get_fignums() == before  # nothing registered with pyplot
    assert mpl.rcParams["font.size"] == font  # the module's style does not leak


# --------------------------------------------------------------------------------------------
# Feature names and the figures of campaigns (validation and diagnosis)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("key", "label"), [
    ("x1_peak_mean_g", "x1 mean of 200 ms peaks (g)"),
    ("x5_peak_std_g", "x5 std of 200 ms peaks (g)"),
    ("x5_band_100_200_g", "x5 band RMS 100-200 Hz (g)"),
    ("x1_band_0p5_20_g", "x1 band RMS 0.5-20 Hz (g)"),
    ("x1_impact_hz", "x1 impact rate (Hz)"),
    ("x1_impacts_per_cycle", "x1 impacts per cycle (\u2013)"),
    ("x5_x1_peak_ratio", "x5/x1 ratio of 200 ms peaks (\u2013)"),
    ("x1_clipped_windows", "x1 fraction of clipped windows (\u2013)"),
    ("z_impact", "Z* at #2 impact face (impacts/cycle)"),
    ("odd_thing_hz", "odd thing (Hz)"),
    ("odd", "odd (\u2013)"),
])
def test_feature_label_names_a_feature_with_its_unit(key, label):
    assert feature_label(key) == label


CAMPAIGN_FLOWS = (200.0, 400.0, 600.0)
CAMPAIGN_KEYS = ("x1_peak_mean_g", "x5_band_100_200_g", "x1_impact_hz", "x5_x1_peak_ratio")


def fake_campaign(wob: float | None = None) -> SimpleNamespace:
    events = [SimpleNamespace(id=f"e0{i + 1}", flow_gpm=q, wob_klbf=20.0)
              for i, q in enumerate(CAMPAIGN_FLOWS)]
    return SimpleNamespace(name="synthetic 7in-cde", wob_klbf=wob, events=events,
                           sensors={"x1": None, "x5": None})


def fake_recorded() -> dict[str, dict[str, Feature]]:
    return {f"e0{i + 1}": {k: Feature(10.0 + i + j, 1.0, 10) for j, k in enumerate(CAMPAIGN_KEYS)}
            for i in range(len(CAMPAIGN_FLOWS))}


def fake_diagnosis() -> SimpleNamespace:
    """What the diagnosis figures read of a vadsim.fit.diagnosis.Diagnosis (no model run)."""
    eids = [f"e0{i + 1}" for i in range(len(CAMPAIGN_FLOWS))]
    # held-out z grows with the key's position, so the order of the panels is known
    heldout = {e: {k: (j + 1) * (i + 1) * 0.5 for j, k in enumerate(CAMPAIGN_KEYS)}
               for i, e in enumerate(eids)}
    sim = {e: {k: 12.0 + j for j, k in enumerate(CAMPAIGN_KEYS)} for e in eids}
    return SimpleNamespace(
        campaign=fake_campaign(), recorded=fake_recorded(),
        none_fit=SimpleNamespace(key="none", heldout=heldout, heldout_sim=sim),
        chosen=SimpleNamespace(key="hydraulic_force[anvil]", heldout_sim=sim),
        settings={"cycles": 160.0, "analyse_cycles": 100.0})


def fake_validation() -> SimpleNamespace:
    """What the validation figures read of a vadsim.fit.validate.ValidationResult."""
    rec = fake_recorded()
    sims = {e: SimpleNamespace(sensor=dict(f), full=dict(f)) for e, f in rec.items()}
    res = pd.DataFrame({k: [0.5, -1.0, 2.0] for k in CAMPAIGN_KEYS}, index=list(rec))
    return SimpleNamespace(campaign=fake_campaign(wob=18.0), recorded=rec, simulations=sims,
                           residuals=res, residuals_full=res * 2,
                           preset=SimpleNamespace(name="7in-cde"),
                           settings={"cycles": 400.0, "analyse_cycles": 200.0})


def all_texts(fig: Figure) -> list[str]:
    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def test_heldout_features_label_each_panel_in_words_with_units(tmp_path):
    diag = fake_diagnosis()
    fig = plots.heldout_features_figure(diag)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    ranked = list(reversed(CAMPAIGN_KEYS))  # largest held-out error first
    assert [ax.get_title() for ax in axes] == ranked
    assert [ax.get_ylabel() for ax in axes] == [feature_label(k) for k in ranked]
    assert axes[0].get_ylabel() == "x5/x1 ratio of 200 ms peaks (\u2013)"
    assert axes[1].get_ylabel() == "x1 impact rate (Hz)"
    assert all(ax.get_xlabel() == "flow rate (gal/min)" for ax in axes)
    assert "recorded: mean \u00b1 std over 200 ms windows" in legend_texts(axes[0])
    title = fig.get_suptitle()
    assert "WOB 20 klbf" in title and "runs of 160 cycles (last 100 analysed)" in title
    assert not any("gpm" in t for t in all_texts(fig))
    assert plots.heldout_features(diag, tmp_path) == ["heldout_features.png"]
    assert (tmp_path / "heldout_features.png").stat().st_size > 1000


def test_mismatch_base_names_features_and_flows(tmp_path):
    diag = fake_diagnosis()
    fig = plots.mismatch_base_figure(diag)
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == [feature_label(k)
                                                            for k in CAMPAIGN_KEYS]
    assert "x5 band RMS 100-200 Hz (g)" in [t.get_text() for t in ax.get_xticklabels()]
    assert [t.get_text() for t in ax.get_yticklabels()] == [
        "e01 (200 gal/min)", "e02 (400 gal/min)", "e03 (600 gal/min)"]
    assert "WOB 20 klbf" in ax.get_title() and "160 cycles" in ax.get_title()
    assert not any("gpm" in t for t in all_texts(fig))
    assert plots.mismatch_base(diag, tmp_path) == ["mismatch_base.png"]
    assert (tmp_path / "mismatch_base.png").stat().st_size > 1000


def test_validation_figures_name_features_units_and_conditions():
    result = fake_validation()
    fig = plots.validation_peaks(result)
    assert [ax.get_ylabel() for ax in fig.axes] == ["x1 mean of 200 ms peaks (g)"]
    assert fig.axes[0].get_xlabel() == "flow rate (gal/min)"
    assert "recorded: mean \u00b1 std over 200 ms windows" in legend_texts(fig.axes[0])
    title = " ".join(fig.get_suptitle().split())   # wrapped to fit the figure
    assert "WOB 18 klbf" in title
    assert "runs of 400 cycles (last 200 analysed)" in title
    fig = plots.validation_mismatch(result)
    ticks = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert ticks[0] == "x1 mean of 200 ms peaks (g)"
    assert ticks[len(CAMPAIGN_KEYS)] == "x1 mean of 200 ms peaks (g) [full res.]"
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()][0] == "e01 (200 gal/min)"
    assert not any("gpm" in t for t in all_texts(fig))
    result.residuals = result.residuals * np.nan
    assert plots.validation_mismatch(result) is None
