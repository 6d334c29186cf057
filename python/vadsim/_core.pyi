"""Type stub of the C++ core (cpp/bindings/bindings.cpp)."""

import enum

import numpy as np
import numpy.typing as npt

__version__: str
N_DOF: int
N_SURFACES: int
EXCITATION_HZ_RANGE: tuple[float, float]

class SolverError(RuntimeError): ...

class ContactLawKind(enum.Enum):
    KelvinVoigt = 0
    KelvinVoigtNoTension = 1
    HuntCrossley = 2
    PowerDamping = 3
    PowerDampingImpact = 4

class Method(enum.Enum):
    BDF = 0
    Adams = 1

class Record(enum.Enum):
    None_ = 0
    Window = 1
    All = 2

class Steady(enum.Enum):
    Full = 0
    Auto = 1

class Params:
    law: ContactLawKind
    m1: float
    m2: float
    m3: float
    m4: float
    m5: float
    m6: float
    m7: float
    k3: float
    k4: float
    k5: float
    k6: float
    k7: float
    c3: float
    c4: float
    c5: float
    c6: float
    c7: float
    kS: float
    kI: float
    kOn: float
    kOff: float
    kR: float
    cS: float
    cI: float
    cOn: float
    cOff: float
    cR: float
    cD: float
    Fo: float
    alpha: float
    beta: float
    phi: float
    psi: float
    L1: float
    L2: float
    L3: float
    LS: float
    LI: float
    LOn: float
    LR: float
    l0: float
    wob: float
    theta0: float
    L_gap: float
    hc_n: float
    hc_alpha: float
    pd_factor: float
    pd_shape: float
    pd_dc: float
    pd_spring: float
    def __init__(self) -> None: ...
    def validate(self) -> None: ...
    def gap(self) -> float: ...
    def spring_length(self) -> float: ...
    def excitation_hz(self, flow_gpm: float) -> float: ...
    def flow_range_gpm(self) -> tuple[float, float]: ...
    def get(self, name: str) -> float: ...
    def set(self, name: str, value: float) -> None: ...
    def __getstate__(self) -> dict[str, float]: ...
    def __setstate__(self, state: dict[str, float]) -> None: ...

def param_table() -> list[tuple[str, str, str, str, float, float]]:
    """(name, unit, meaning, rule, lo, hi): "non-negative" allows 0 or [lo, hi], "optional"
    nan (unset) or [lo, hi], the other rules [lo, hi]."""

class ExtraForce:
    @property
    def name(self) -> str: ...

class HydraulicForce(ExtraForce):
    def __init__(self, dof: int, c: float, n: float = ...) -> None: ...

class CoulombFriction(ExtraForce):
    def __init__(self, dof_a: int, dof_b: int, force: float, v_eps: float,
                 static_force: float = ..., v_s: float = 0.05) -> None: ...

class SpringDashpot(ExtraForce):
    def __init__(self, dof_a: int, dof_b: int, k: float, c: float) -> None: ...

class Model:
    def __init__(self, params: Params, extras: list[ExtraForce] = ...) -> None: ...
    @property
    def params(self) -> Params: ...
    @property
    def static_positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def x_top(self) -> float: ...
    @property
    def rest_phase(self) -> float: ...
    def indentation(self, surface: int, y: npt.ArrayLike) -> float: ...
    def rhs(
        self, t: float, flow_gpm: float, y: npt.ArrayLike, modes: list[int]
    ) -> npt.NDArray[np.float64]: ...
    def jacobian(
        self, t: float, flow_gpm: float, y: npt.ArrayLike, modes: list[int]
    ) -> npt.NDArray[np.float64]: ...
    def energy(self, y: npt.ArrayLike, modes: list[int]) -> float: ...

class RunOptions:
    flow_gpm: float
    cycles: float
    analyse_cycles: float
    method: Method
    rtol: float
    atol: float
    max_step: float
    record: Record
    output_rate_hz: float
    accelerations_only: bool
    summary_rate_hz: float
    peak_window_s: float
    max_steps: int
    max_events: int
    initial_state: npt.NDArray[np.float64] | None
    initial_displacement: npt.NDArray[np.float64] | None
    steady: Steady
    steady_max_period: int
    steady_min_cycles: float
    steady_confirm_cycles: int
    steady_tol: float
    orbit_rate_hz: float
    orbit_replaces_window: bool
    def __init__(self) -> None: ...
    def steady_tolerance(self) -> float: ...
    def step_budget(self) -> int: ...
    def event_budget(self) -> int: ...
    def validate(self, params: Params = ...) -> None: ...

class SolverStats:
    steps: int
    rhs_evals: int
    jac_evals: int
    lin_setups: int
    err_test_fails: int
    nonlin_iters: int
    nonlin_conv_fails: int
    root_evals: int
    reinits: int

class WindowSummary:
    t0: float
    t1: float
    rate_hz: float
    samples: int
    onsets: list[int]
    impulse_mean: float
    impulse_pos: float
    window_peaks: npt.NDArray[np.float64]

class SteadyInfo:
    enabled: bool
    period: int
    detected_cycle: float
    stopped_cycle: float
    residual: float
    tolerance: float
    window_on_orbit: bool

class RunResult:
    flow_gpm: float
    f_exc_hz: float
    t_end: float
    t: npt.NDArray[np.float64]
    x: npt.NDArray[np.float64]
    v: npt.NDArray[np.float64]
    a: npt.NDArray[np.float64]
    fc: npt.NDArray[np.float64]
    fh: npt.NDArray[np.float64]
    poincare_t: npt.NDArray[np.float64]
    poincare: npt.NDArray[np.float64]
    summary: WindowSummary
    stats: SolverStats
    y_end: npt.NDArray[np.float64]
    x_static: npt.NDArray[np.float64]
    steady: SteadyInfo
    orbit_t: npt.NDArray[np.float64]
    orbit_a: npt.NDArray[np.float64]
    orbit_corner_t: npt.NDArray[np.float64]
    orbit_corner_before: npt.NDArray[np.float64]
    orbit_corner_after: npt.NDArray[np.float64]
    orbit_period_s: float
    @property
    def event_t(self) -> npt.NDArray[np.float64]: ...
    @property
    def event_surface(self) -> npt.NDArray[np.int32]: ...
    @property
    def event_kind(self) -> npt.NDArray[np.int32]: ...
    @property
    def event_rel_velocity(self) -> npt.NDArray[np.float64]: ...

def simulate(model: Model, options: RunOptions) -> RunResult:
    """GIL released; on the main thread, a signal handler that raises (Ctrl-C) stops the run
    within 2000 steps and its exception propagates, with a note of where the run stopped; in
    any thread, request_interrupt() stops it the same way with KeyboardInterrupt."""

def request_interrupt() -> None:
    """Ask every run in progress in this process, in any thread, to stop within 2000 steps
    (KeyboardInterrupt); runs started before clear_interrupt() stop at once."""

def clear_interrupt() -> None:
    """Withdraw request_interrupt()."""

def interrupt_requested() -> bool:
    """Whether request_interrupt() is in force."""
