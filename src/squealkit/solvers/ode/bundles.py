"""The named bundles the integrators take: a kernel's signature reads as a handful of these, not 55 arrays.

Each is a ``NamedTuple`` (numba types it field by field, so a kernel reads ``model.C[r]`` or
``span.t_b`` at no cost); :mod:`squealkit.transient._driver` builds them for each chunk, in one place
(``_bundles``). R runs of n DOF, m = 2n states; all arrays C-contiguous float64 unless said.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class State(NamedTuple):
    """What carries over from chunk to chunk, updated in place."""

    X: np.ndarray  #: (R, n) displacements [m]
    V: np.ndarray  #: (R, n) velocities [m/s]
    H: np.ndarray  #: (R,) step size [s]: the error control's next step (adaptive), the fixed step (RK4)


class Model(NamedTuple):
    """Each run's model, premultiplied by M^-1 (the right-hand side is the acceleration; see :mod:`.force`)."""

    bM: np.ndarray    #: (R, n) M^-1 b (contact normal)
    fM: np.ndarray    #: (R, n) M^-1 f (friction direction)
    C: np.ndarray     #: (R, n, n) M^-1 C
    K0: np.ndarray    #: (R, n, n) M^-1 K0, the structure's stiffness
    Kn: np.ndarray    #: (R, n, n) M^-1 Kn, normal contact stiffness
    Kf: np.ndarray    #: (R, n, n) M^-1 Kf, friction part
    Knx: np.ndarray   #: (R, n, n) slope coupling of Kn (consistent kinematics)
    Kfx: np.ndarray   #: (R, n, n) slope coupling of Kf
    kin: np.ndarray   #: (R,) 1.0 with consistent kinematics, else 0.0
    F0: np.ndarray    #: (R, n) M^-1 F0, the preload
    fn: np.ndarray    #: (R, n) M^-1 fn, the run-out's normal load per metre
    ff: np.ndarray    #: (R, n) M^-1 ff, its friction part
    b: np.ndarray     #: (R, n) contact normal b (N cos theta = -kc (b.x - q))
    fhat: np.ndarray  #: (R, n) unit friction direction
    kc: np.ndarray    #: (R,) contact stiffness [N/m]
    s: np.ndarray     #: (R,) sliding direction, +-1
    mu: np.ndarray    #: (R,) friction coefficient
    v: np.ndarray     #: (R,) sliding speed [m/s]
    vq: np.ndarray    #: (R,) speed at which the profile passes (its forcing's interpolation): 0 for a held slope
    opts: np.ndarray  #: (7,) the contact law's flags (:meth:`squealkit.transient.Contact.options`)


class Forcing(NamedTuple):
    """The surface profile sampled for one chunk, at times ``t0 + k h``."""

    q: np.ndarray          #: (R, G) run-out q [m]
    tan_theta: np.ndarray  #: (R, G) slope tan(theta)
    t0: float              #: time of the first sample [s]
    h: float               #: spacing [s] (RK4: half its step, the samples are its stages' times)


class Span(NamedTuple):
    """One chunk of an adaptive run: integrate over ``[t_a, t_b]``, write samples ``o_first..o_last``."""

    t_a: float
    t_b: float
    fs: float     #: output rate [Hz]: sample o is at o / fs
    o_first: int
    o_last: int
    o_base: int   #: sample o goes to row ``o - o_base`` of the output buffers


class Steps(NamedTuple):
    """One chunk of an RK4 run: ``n_steps`` steps, a sample every ``stride`` steps, the first ``o_start``."""

    n_steps: int
    stride: int
    o_start: int
    o_base: int


class Control(NamedTuple):
    """Tolerances and bounds."""

    rtol: float
    atol: np.ndarray   #: (R, m) absolute tolerance per state component (x then x')
    h_max: np.ndarray  #: (R,) largest step [s]
    limit: float       #: divergence: a run stops when some |x_i| exceeds it [m]


class Outputs(NamedTuple):
    """One chunk's output buffers (NaN where nothing was written)."""

    x: np.ndarray   #: (R, k, n) displacements
    v: np.ndarray   #: (R, k, n) velocities
    a: np.ndarray   #: (R, k, n) accelerations
    nc: np.ndarray  #: (R, k) N cos(theta)
    me: np.ndarray  #: (R, k) effective friction coefficient


class Log(NamedTuple):
    """Per-run status, counters and events, kept over the whole run (RK4 writes ``status`` and ``n_valid`` only)."""

    status: np.ndarray   #: (R,) int64: 0 running, 1 diverged, 2 step size underflow
    n_valid: np.ndarray  #: (R,) int64: samples written
    counts: np.ndarray   #: (R, 4) accepted steps, rejected steps, rhs calls, smallest step
    ev_t: np.ndarray     #: (R, E) event times [s]
    ev_k: np.ndarray     #: (R, E) int64 event codes (:mod:`.events`)
    n_ev: np.ndarray     #: (R,) int64 events (counted beyond E too)


class DP5Tableau(NamedTuple):
    """Dormand-Prince 5(4) (see :mod:`.dp5`)."""

    A: np.ndarray      #: (S, S) stage coefficients
    B: np.ndarray      #: (S,) 5th-order weights
    C: np.ndarray      #: (S,) stage times
    E: np.ndarray      #: (S + 1,) error weights b5 - b4
    dense: np.ndarray  #: (S + 1, 4) dense output P


class Rodas4Tableau(NamedTuple):
    """Rodas4 in the transformed variables (see :mod:`.rosenbrock`)."""

    A: np.ndarray      #: (6, 6) a_ij
    C: np.ndarray      #: (6, 6) c_ij
    alpha: np.ndarray  #: (6,) stage times
    d: np.ndarray      #: (6,) f_t weights
    m: np.ndarray      #: (6,) solution weights
    dense: np.ndarray  #: (2, 6) dense output D2, D3
    gamma: float
