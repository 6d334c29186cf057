"""Output that explains itself (issue 37): each text a newcomer met without an explanation.

One test per fix: the run table's columns are explained under it; ``vadsim presets`` is
aligned and says what each preset is for (and what -cal and -thesis mean); a preset's
parameters say they are per kg of m*; ``repr(result)`` is a short summary, not 249 lines of
arrays; an unknown parameter gets "did you mean"; the regime comparison fits 80 columns and
says which preset meets the bands; figure titles fit inside their figures. (The diagnosis
summary's terms: tests/python/fit/diagnosis/test_diagnose.py::test_summary_explains_its_terms.)
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import vadsim
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from vadsim import plots
from vadsim.campaigns import Sensor
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.cli import main
from vadsim.fit.validate import validate
from vadsim.model.presets import PRESETS
from vadsim.studies import thesis


def test_run_table_columns_are_explained(capsys):
    assert main(["run", "7in-cde", "--flow", "200", "--cycles", "20", "--analyse", "10"]) == 0
    out = capsys.readouterr().out
    header = next(line for line in out.splitlines() if line.strip().startswith("Q gal/min"))
    legend = out[out.index(header) + len(header):]
    for column, meaning in (("Z1-Z4", "impacts per excitation cycle"), ("sc", "impact scenario"),
                            ("x1 / x5 peak", "200 ms window"), ("+-", "std of the x1 peaks"),
                            ("J*", "per kg of the reference mass m* (N/kg)")):
        assert column in legend and meaning in legend.replace("\n", " "), column


def test_presets_listing_is_aligned_and_says_what_each_is_for(capsys):
    assert main(["presets"]) == 0
    lines = capsys.readouterr().out.splitlines()
    table = lines[:1 + len(PRESETS)]
    assert table[0].startswith("preset")
    # aligned: every column of every row ends where the header's does
    ends = [m.end() for m in re.finditer(r"\S+(?: \S+)?(?=\s{2,}|$)", table[0])]
    for row in table[1:]:
        assert len(row) == len(table[0]), row
        for end in ends[3:]:          # the numeric columns are right-aligned
            assert row[end - 1] != " ", (row, end)
    roles = lines[lines.index("what each is for:") + 1:]
    for name in PRESETS:
        assert any(line.split()[0] == name and len(line.split()) > 3 for line in roles), name
    text = "\n".join(lines)
    assert "-cal: the length unit l0 and wob calibrated" in text
    assert "-thesis: the excitation phase at rest theta0" in text
    assert max(len(line) for line in lines) <= 100


def test_preset_parameters_say_they_are_mass_normalised(capsys):
    assert main(["presets", "7in-cde"]) == 0
    out = capsys.readouterr().out
    assert "per unit reference mass m* = 17.79 kg" in out
    assert "stiffnesses in N/m per kg of m*" in out


def test_repr_of_a_result_is_a_short_summary():
    r = vadsim.simulate("7in-cde", 200, cycles=40, analyse_cycles=20)
    text = repr(r)
    assert len(text.splitlines()) <= 25
    assert "array(" not in text and "200 gal/min" in text and "scenario" in text
    assert f"{r.t.size} samples" in text


@pytest.mark.parametrize("typo, suggestion", [("ks", "kS"), ("kSS", "kS"), ("Fo0", "Fo"),
                                              ("wob_n_per_k", "wob_n_per_kg")])
def test_unknown_parameter_says_did_you_mean(typo, suggestion):
    with pytest.raises(ValueError, match=rf"unknown parameter '{typo}' \(did you mean "
                                         rf"'{suggestion}'"):
        vadsim.simulate("7in-cde", 200, cycles=2, analyse_cycles=1, overrides={typo: 1.0})


def test_regime_comparison_fits_80_columns_and_names_the_thesis_preset():
    q = np.arange(200, 660, 10.0)
    sc = np.where(q <= 310, 1, np.where(q <= 450, 3, np.where(q <= 500, 4, 5)))  # no 2
    ds = xr.Dataset(coords={"flow_gpm": q})
    ds["scenario"] = ("flow_gpm", sc.astype(np.int64))
    ds.attrs.update(preset="7in-cde", mode="continuation")
    text = thesis.regimes_summary(ds)
    assert max(len(line) for line in text.splitlines()) <= 80
    assert "..." not in text
    assert "none (regime 2): the sweep never shows that scenario" in text.replace("\n", " ")
    assert "Preset 7in-cde-thesis (theta0 = 2.475 rad) is the one chosen to meet the bands" \
        in text.replace("\n", " ")
    ds.attrs["preset"] = "7in-cde-thesis"
    assert "7in-cde-thesis (theta0" not in thesis.regimes_summary(ds)


def _titles_inside(fig: Figure) -> list[str]:
    """Each title (figure's and axes') that crosses the figure's edge, after a draw."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    texts = [getattr(fig, "_suptitle", None), *(ax.title for ax in fig.axes)]
    bad = []
    for t in texts:
        if t is None or not t.get_text():
            continue
        box = t.get_window_extent(canvas.get_renderer())
        if box.x0 < -0.5 or box.x1 > fig.bbox.width + 0.5:
            bad.append(t.get_text())
    return bad


def test_validation_figure_titles_fit_their_figures():
    # one sensor: the narrowest figures (6.5 in), where the thesis campaigns' titles were cut
    camp = synthetic_campaign("7in-cde", (200, 400), cycles=60, analyse_cycles=30, seed=1,
                              sensors={"x1": Sensor("x1", 1, 1024.0, 250.0)},
                              name="A field test with the long name a real campaign has "
                              "(CTTF-2015-03-26, rig 12, well A-7)")
    res = validate(camp, cycles=60, analyse_cycles=30, progress=False)
    peaks, heat = plots.validation_peaks(res), plots.validation_mismatch(res)
    assert heat is not None
    for fig in (peaks, heat):
        assert _titles_inside(fig) == []
    # the campaign's name is still there, whole, only broken over lines
    assert "well A-7" in peaks._suptitle.get_text()


def test_a_wide_heat_map_stays_legible():
    """A diagnosis' base-model heat map has 80+ features (the gallery's thumbnail was that
    map squashed): no cell numbers printed over each other, no labels over each other."""
    import pandas as pd

    rng = np.random.default_rng(0)
    cols = [f"x1 fold {i:02d} (g)" for i in range(87)]
    table = pd.DataFrame(rng.normal(0, 2, (6, 87)), columns=cols,
                         index=[f"e0{i} ({200 + 90 * i} gal/min)" for i in range(1, 7)])
    fig = plots.mismatch_heatmap(table)
    ax = fig.axes[0]
    assert len(ax.texts) == 0               # the colours carry it; numbers would overlap
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    boxes = [t.get_window_extent(canvas.get_renderer()) for t in ax.get_xticklabels()]
    assert all(a.x1 <= b.x0 + 0.5 for a, b in zip(boxes, boxes[1:], strict=False))
    assert _titles_inside(fig) == []
    # a narrow table keeps its numbers
    assert len(plots.mismatch_heatmap(table.iloc[:, :5]).axes[0].texts) == 30
