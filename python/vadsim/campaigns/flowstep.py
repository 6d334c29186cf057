"""A synthetic flow-step test: one continuous downhole record and the rig's surface log.

Why this module exists: an import (:func:`~vadsim.campaigns.importing.import_campaign`) is
only trustworthy if it finds what was put in. :func:`flow_step_test` writes what a field test
leaves behind: the pumps off for a few seconds, then the flow stepped through a list of
rates with the model's state carried across each step (``simulate(..., initial_state=)``, so
every step starts from the last one's motion, as a real tool does), each sensor's signal
through its chain (sampling, noise, clipping) as one continuous record in a vendor's form
(m/s^2, its own column names), and a surface log at 1 Hz on a clock that is off by
``clock_offset_s``, each row the average over its second plus noise. The truth (the steps
on the record clock, the offset) is kept on the returned :class:`FlowStepTest`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from vadsim.campaigns.format import Sensor
from vadsim.campaigns.synthetic import DEFAULT_SENSORS
from vadsim.model.presets import get_preset
from vadsim.model.result import G, SimulationResult
from vadsim.model.settings import RunSettings
from vadsim.model.simulation import simulate
from vadsim.signals.sensor import SIMULATION_OVERSAMPLING, sensor_chain

__all__ = ["RECORD_COLUMNS", "FlowStepTest", "flow_step_test"]

#: The record's column per sensor, as a vendor might name them (values in m/s^2).
RECORD_COLUMNS: dict[str, str] = {"x1": "AccZ_bit", "x5": "AccZ_mwd"}

_FLOW_COLUMNS = {"gal/min": "Flow [gpm]", "L/min": "Flow [L/min]"}
_WOB_COLUMNS = {"klbf": "WOB [klbf]", "kN": "WOB [kN]"}
_LPM = 3.785411784
_KN = 4.4482216152605


@dataclass
class FlowStepTest:
    """A written flow-step test and its truth.

    Attributes
    ----------
    record
        The downhole record: ``Time`` (s, record clock) and one column per sensor
        (:data:`RECORD_COLUMNS`), in m/s^2.
    surface
        The surface log: ``Time`` (s, surface clock), flow and WOB (units as chosen).
    steps
        ``(start_s, end_s, flow_gpm)`` of each step on the record clock.
    clock_offset_s
        Surface time minus record time (what an import should recover).
    pumps_on_s
        When the flow came on, record clock.
    sensors
        The sensors the record was written with.
    """

    record: pd.DataFrame
    surface: pd.DataFrame
    steps: list[tuple[float, float, float]]
    clock_offset_s: float
    pumps_on_s: float
    wob_klbf: float
    sensors: dict[str, Sensor] = field(default_factory=dict)

    @property
    def columns(self) -> dict[str, str]:
        """Sensor -> record column (the ``--column`` options an import needs)."""
        return {s: RECORD_COLUMNS.get(s, s) for s in self.sensors}

    def write_record(self, path: str | Path) -> Path:
        """Write the record as CSV, Parquet, HDF5 or LAS 2.0 (by the suffix), with its units
        where the format keeps them (CSV: in the header, ``AccZ_bit [m/s^2]``)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        units = {"Time": "s", **{c: "m/s^2" for c in self.columns.values()}}
        _write_table(self.record, units, path)
        return path

    def write_surface(self, path: str | Path) -> Path:
        """Write the surface log as CSV, Excel (.xlsx) or LAS 2.0 (by the suffix)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        units = {c: c.split("[")[1].rstrip("]") for c in self.surface.columns if "[" in c}
        frame = self.surface.rename(columns=lambda c: c.split(" [")[0])
        _write_table(frame, {k.split(" [")[0]: v for k, v in units.items()} | {"Time": "s"},
                     path)
        return path


def _write_table(frame: pd.DataFrame, units: Mapping[str, str], path: Path) -> None:
    suffix = path.suffix.lower()
    if suffix == ".csv":
        named = frame.rename(columns=lambda c: f"{c} [{units[c]}]" if c in units else c)
        named.to_csv(path, index=False, float_format="%.9g")
    elif suffix == ".xlsx":
        frame.rename(columns=lambda c: f"{c} [{units[c]}]" if c in units else c).to_excel(
            path, index=False)
    elif suffix in (".parquet", ".pq"):
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(frame, preserve_index=False)
        fields = [f.with_metadata({"units": units[f.name]}) if f.name in units else f
                  for f in table.schema]
        pq.write_table(table.cast(pa.schema(fields)), path)
    elif suffix in (".h5", ".hdf5"):
        import h5py

        with h5py.File(path, "w") as fh:
            for c in frame.columns:
                ds = fh.create_dataset(c, data=frame[c].to_numpy())
                if c in units:
                    ds.attrs["units"] = units[c]
    elif suffix == ".las":
        import lasio

        las = lasio.LASFile()
        for c in frame.columns:
            las.append_curve(c, frame[c].to_numpy(), unit=units.get(c, ""))
        with path.open("w") as fh:
            las.write(fh, version=2.0, fmt="%.10g")
    else:
        raise ValueError(f"{path}: write .csv, .xlsx, .parquet, .h5 or .las")


def _run_steps(preset: str, flows: Sequence[float], durations: Sequence[float],
               wob_klbf: float, fine_hz: float) -> list[tuple[float, SimulationResult]]:
    """Each step's run from the previous one's end state, with its flow-on duration."""
    settings = RunSettings(get_preset(preset))
    prev: SimulationResult | None = None
    runs = []
    for q, dur in zip(flows, durations, strict=True):
        n = math.ceil(dur * settings.f_exc_hz(q))
        r = simulate(preset, q, cycles=n, analyse_cycles=n, wob_klbf=wob_klbf, record="all",
                     output_rate_hz=fine_hz, summary_rate_hz=0, initial_state=prev,
                     accelerations_only=True)
        runs.append((float(r.window[1]), r))
        prev = r
    return runs


def flow_step_test(
    preset: str = "7in-cde",
    flows: Sequence[float] = (200.0, 300.0, 400.0, 500.0, 600.0, 650.0),
    *,
    step_s: float | Sequence[float] = 12.0,
    quiet_s: float = 4.0,
    wob_klbf: float | None = None,
    sensors: Mapping[str, Sensor] | None = None,
    noise_g: float = 0.3,
    clock_offset_s: float = 37.3,
    surface_rate_hz: float = 1.0,
    flow_noise_gpm: float = 2.0,
    wob_noise_klbf: float = 0.05,
    flow_unit: str = "gal/min",
    wob_unit: str = "klbf",
    seed: int = 0,
) -> FlowStepTest:
    """Simulate a flow-step test as one continuous record and a surface log.

    Why so many parameters: the test is a flow program (flows, step and settle times), a model
    run and a vendor's files (units, clock offset, log rate); each is one of those, keyword-only
    with defaults.

    Parameters
    ----------
    preset
        The model that writes the record.
    flows
        The flow steps (gal/min), in order.
    step_s
        How long each step lasts (one value or one per step), s; rounded up to whole
        excitation cycles.
    quiet_s
        Pumps off at the start of the record (what a clock alignment looks for).
    wob_klbf
        Weight on bit (default the preset's).
    sensors
        Default :data:`~vadsim.campaigns.synthetic.DEFAULT_SENSORS` (x1, x5 at 1024 Hz).
    noise_g
        The sensors' noise, g RMS.
    clock_offset_s
        Surface clock minus record clock.
    surface_rate_hz, flow_noise_gpm, wob_noise_klbf
        The surface log's rate (its rows are averages over their period) and noise.
    flow_unit, wob_unit
        Units of the surface log: ``gal/min`` or ``L/min``; ``klbf`` or ``kN``.
    seed
        Seeds the sampling phase and all noise.
    """
    p = get_preset(preset)
    sensors = dict(sensors or DEFAULT_SENSORS)
    wob = float(p.wob_klbf if wob_klbf is None else wob_klbf)
    durations = ([float(step_s)] * len(flows) if isinstance(step_s, int | float)
                 else [float(d) for d in step_s])
    rate = max(s.rate_hz for s in sensors.values())
    fine = SIMULATION_OVERSAMPLING * rate
    runs = _run_steps(p.name, flows, durations, wob, fine)
    steps, start = [], quiet_s
    for (dur, _), q in zip(runs, flows, strict=True):
        steps.append((start, start + dur, float(q)))
        start += dur
    grid = np.arange(0.0, start, 1.0 / fine)
    rng = np.random.default_rng(seed)
    phase = float(rng.uniform(0.0, 1.0))
    columns: dict[str, np.ndarray] = {}
    t_s = np.array([])
    for name, s in sensors.items():
        a = np.zeros_like(grid)
        for (t0, t1, _), (_, r) in zip(steps, runs, strict=True):
            inside = (grid >= t0) & (grid < t1)
            a[inside] = np.interp(grid[inside] - t0, r.t, r.a[:, s.dof - 1] / G)
        t_s, a_s, _ = sensor_chain(grid, a, rate_hz=s.rate_hz, range_g=s.range_g,
                                   lowpass_hz=s.lowpass_hz, phase=phase, noise_g=noise_g,
                                   rng=rng)
        columns[RECORD_COLUMNS.get(name, name)] = a_s * G
    n = min(c.size for c in columns.values())
    record = pd.DataFrame({"Time": np.round(t_s[:n], 7),
                           **{k: v[:n] for k, v in columns.items()}})
    surface = _surface_log(steps, start, clock_offset_s, surface_rate_hz, wob, flow_noise_gpm,
                           wob_noise_klbf, flow_unit, wob_unit, rng)
    return FlowStepTest(record, surface, steps, clock_offset_s, quiet_s, wob, sensors)


def _surface_log(steps: list[tuple[float, float, float]], end_s: float, offset_s: float,
                 rate_hz: float, wob: float, flow_noise: float, wob_noise: float,
                 flow_unit: str, wob_unit: str, rng: np.random.Generator) -> pd.DataFrame:
    """Rows every 1/rate_hz s on the surface clock, each the mean over its period, + noise."""
    period = 1.0 / rate_hz
    t_surface = np.arange(0.0, end_s + offset_s - period, period)
    sub = (np.arange(20) + 0.5) / 20 - 0.5          # 20 points across each row's period
    t_rec = (t_surface[:, None] + sub[None, :] * period) - offset_s
    flow = np.zeros_like(t_rec)
    for t0, t1, q in steps:
        flow[(t_rec >= t0) & (t_rec < t1)] = q
    on = flow.mean(axis=1)
    q_mean = on + rng.normal(0.0, flow_noise, t_surface.size)
    w = np.where(on > 0, wob, 0.0) + rng.normal(0.0, wob_noise, t_surface.size)
    q_mean = np.maximum(q_mean, 0.0)
    flow_factor = _LPM if flow_unit == "L/min" else 1.0
    wob_factor = _KN if wob_unit == "kN" else 1.0
    return pd.DataFrame({"Time": t_surface,
                         _FLOW_COLUMNS[flow_unit]: np.round(q_mean * flow_factor, 2),
                         _WOB_COLUMNS[wob_unit]: np.round(w * wob_factor, 3)})
