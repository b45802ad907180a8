"""Disc surface profiles: the run-out q(x) [m] and its slope tan(theta) = dq/dx.

Each profile is a small frozen dataclass with :meth:`~SurfaceProfile.evaluate`, which maps
positions ``x`` [m] along the sliding path to ``(q, tan_theta)``. The transient solver
samples it at ``x = x_start + v t`` (paper eqs. 9-11).

- :class:`Smooth`: no run-out (paper Fig. 3).
- :class:`ConstantIncline`: a slope tan(theta) held fixed on the mean surface, q = 0: the frozen
  incline of the stability map and the limit cycles (eqs. 4-7 at one (mu, theta)).
- :class:`SineRunOut`: ``q = q0 sin(2 pi x / lambda)`` (paper eq. 9, Fig. 4).
- :class:`SampledProfile`: a measured or synthetic profile, q against position, from an
  array or a two-column text file; interpolated by a C2 cubic spline.
- :class:`RandomRoughness`: band-limited random roughness drawn from a seeded generator.
- :class:`DiscRunOut`: a rotating disc whose profile repeats every revolution: macro
  run-out in low orders plus micro run-out (band-limited roughness in high orders).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import InputError, validate_array_finite, validate_finite, validate_positive

__all__ = [
    "ConstantIncline",
    "DiscRunOut",
    "RandomRoughness",
    "SampledProfile",
    "SineRunOut",
    "Smooth",
    "SurfaceProfile",
]

Array = NDArray[np.float64]


class SurfaceProfile:
    """Base of all profiles: ``evaluate(x) -> (q, tan_theta)``, both shaped like ``x``."""

    #: Short name stored in result attributes.
    kind: str = "abstract"
    #: The slope is the derivative of q along the path (the integrator interpolates q in time with
    #: dq/dt = v tan(theta)); False for a profile that holds the slope apart from q (:class:`ConstantIncline`).
    slope_is_dq_dx: bool = True

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:  # pragma: no cover - abstract
        """Run-out q [m] and slope tan(theta) [-] at positions ``x`` [m].

        Parameters
        ----------
        x : array_like
            Positions along the sliding path [m].

        Returns
        -------
        q, tan_theta : ndarray, the shape of ``x``
            Surface height [m] and its slope ``dq/dx`` [1].
        """
        raise NotImplementedError

    def check_range(self, x_start: float, x_stop: float) -> None:
        """Raise :class:`InputError` if the profile is undefined anywhere on [x_start, x_stop].

        Parameters
        ----------
        x_start, x_stop : float
            First and last position [m] a run covers.
        """

    def describe(self) -> str:
        """A one-line description for result attributes."""
        return self.kind


def _harmonics(x: ArrayLike, k: Array, a: Array, phi: Array) -> tuple[Array, Array]:
    """Sum of sines q = sum a sin(k x + phi) and its exact derivative, evaluated in blocks."""
    xa = np.asarray(x, dtype=float)
    flat = xa.ravel()
    q = np.zeros_like(flat)
    dq = np.zeros_like(flat)
    block = max(1, 2**22 // max(1, k.size))
    for i in range(0, flat.size, block):
        arg = np.multiply.outer(flat[i : i + block], k) + phi
        q[i : i + block] = np.sin(arg) @ a
        dq[i : i + block] = np.cos(arg) @ (a * k)
    return q.reshape(xa.shape), dq.reshape(xa.shape)


@dataclass(frozen=True)
class Smooth(SurfaceProfile):
    """A perfectly flat disc: q = 0, tan(theta) = 0 (paper Fig. 3)."""

    kind = "none"

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:
        z = np.zeros(np.shape(x))
        return z, z.copy()


@dataclass(frozen=True)
class ConstantIncline(SurfaceProfile):
    """A run-out incline held fixed: tan(theta) constant on the mean surface q = 0.

    The model's equations of motion (paper eq. 4) take q and tan(theta) as two inputs: tan(theta)
    enters the stiffness through mu_e = mu + tan(theta) and the normal direction (eqs. 2-3, 5-6), q
    only the contact's offset. This profile gives the frozen slope that the stability map
    (:func:`~squealkit.stability.eigenvalues` at (mu, theta)) and the limit cycles
    (:func:`~squealkit.nonlinear.limit_cycle_branch`, ``theta``) assume, for any length of run; its
    slope is not dq/dx (a real plane at that slope would lift the pin by tan(theta) v t).

    Parameters
    ----------
    tan_theta : float
        The incline's slope tan(theta) [1] (``ConstantIncline.from_theta(theta)`` from the angle [rad]).

    Examples
    --------
    >>> p = ConstantIncline(0.05)
    >>> [float(a[0]) for a in p.evaluate([0.0, 1.0])]
    [0.0, 0.05]
    """

    tan_theta: float
    kind = "incline"
    slope_is_dq_dx = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "tan_theta", validate_finite("tan_theta", self.tan_theta))

    @classmethod
    def from_theta(cls, theta: float) -> ConstantIncline:
        """The incline at an angle.

        Parameters
        ----------
        theta : float
            Run-out incline [rad], strictly inside (-pi/2, pi/2).

        Returns
        -------
        ConstantIncline
        """
        theta = validate_finite("theta", theta)
        if not abs(theta) < math.pi / 2:
            raise InputError(f"Parameter theta={theta!r} rad must lie strictly inside (-pi/2, pi/2).")
        return cls(math.tan(theta))

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:
        z = np.zeros(np.shape(x))
        return z, np.full(np.shape(x), self.tan_theta)

    def describe(self) -> str:
        return f"incline tan(theta)={self.tan_theta:g} (theta={math.degrees(math.atan(self.tan_theta)):g} deg), q=0"


@dataclass(frozen=True)
class SineRunOut(SurfaceProfile):
    """Sine run-out q = q0 sin(2 pi x / lambda + phase) (paper eq. 9).

    Parameters
    ----------
    amplitude : float
        q0 [m] (paper Fig. 4: 0.08 mm).
    wavelength : float
        lambda [m] (paper Fig. 4: 1 mm).
    phase : float
        Phase at x = 0 [rad].

    Examples
    --------
    >>> p = SineRunOut(amplitude=0.08e-3, wavelength=1e-3)
    >>> round(float(p.evaluate(0.0)[1]), 4)        # max slope 2 pi q0 / lambda (paper eq. 11)
    0.5027
    """

    amplitude: float
    wavelength: float
    phase: float = 0.0
    kind = "sine"

    def __post_init__(self) -> None:
        object.__setattr__(self, "amplitude", validate_positive("sro_amplitude", self.amplitude, allow_zero=True))
        object.__setattr__(self, "wavelength", validate_positive("sro_wavelength", self.wavelength))
        object.__setattr__(self, "phase", validate_finite("phase", self.phase))

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:
        k = 2.0 * math.pi / self.wavelength
        arg = k * np.asarray(x, dtype=float) + self.phase
        return self.amplitude * np.sin(arg), self.amplitude * k * np.cos(arg)

    def describe(self) -> str:
        return f"sine q0={self.amplitude:g} m lambda={self.wavelength:g} m"


@dataclass(frozen=True, eq=False)
class SampledProfile(SurfaceProfile):
    """A profile sampled at known positions, interpolated by a cubic spline.

    Parameters
    ----------
    position : array_like, shape (m,)
        Strictly increasing positions along the sliding path [m], m >= 4.
    height : array_like, shape (m,)
        Run-out q at those positions [m].
    periodic : bool
        Whether the profile repeats with period ``position[-1] - position[0]`` (a disc
        turn); then ``height[-1]`` must equal ``height[0]``. Otherwise positions outside
        the sampled range are an error.
    source : str, default "array"
        Where the samples came from (the file, for :meth:`from_file`), shown by ``describe()``.
    """

    position: Array
    height: Array
    periodic: bool = False
    source: str = "array"
    kind = "file"
    _spline: object = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from scipy.interpolate import CubicSpline

        pos = validate_array_finite("profile position", self.position)
        h = validate_array_finite("profile height", self.height)
        if pos.ndim != 1 or h.shape != pos.shape:
            raise InputError(
                f"A sampled profile needs 1-D position and height of equal length; "
                f"got shapes {pos.shape} and {h.shape}."
            )
        if pos.size < 4:
            raise InputError(f"A sampled profile needs at least 4 points; got {pos.size}.")
        if np.any(np.diff(pos) <= 0):
            raise InputError("Profile positions must be strictly increasing.")
        if self.periodic and not math.isclose(h[0], h[-1], rel_tol=1e-9, abs_tol=1e-15):
            raise InputError("A periodic profile must end at the height it starts with.")
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "height", h)
        bc = "periodic" if self.periodic else "not-a-knot"
        object.__setattr__(self, "_spline", CubicSpline(pos, h, bc_type=bc))

    @classmethod
    def from_file(cls, path: str | Path, *, periodic: bool = False) -> SampledProfile:
        """Read a two-column text file (position [m], q [m]); commas or blanks; '#' comments.

        Parameters
        ----------
        path : str or Path
            The text file.
        periodic : bool, default False
            Whether the profile repeats (see the class).

        Returns
        -------
        SampledProfile
            With ``source`` the file's path.
        """
        p = Path(path)
        if not p.is_file():
            raise InputError(f"Profile file {str(p)!r} does not exist.")
        try:
            text = p.read_text(encoding="utf-8").replace(",", " ")
            data = np.loadtxt(text.splitlines(), ndmin=2)
        except (OSError, ValueError, UnicodeDecodeError) as e:
            raise InputError(f"Profile file {str(p)!r} is not two numeric columns: {e}") from e
        if data.shape[1] != 2:
            raise InputError(f"Profile file {str(p)!r} has {data.shape[1]} columns; expected 2 (position, q).")
        return cls(data[:, 0], data[:, 1], periodic=periodic, source=str(p))

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:
        xa = np.asarray(x, dtype=float)
        if self.periodic:
            x0, per = self.position[0], self.position[-1] - self.position[0]
            xa = x0 + np.mod(xa - x0, per)
        s = self._spline
        return s(xa), s(xa, 1)  # type: ignore[operator]

    def check_range(self, x_start: float, x_stop: float) -> None:
        if self.periodic:
            return
        lo, hi = self.position[0], self.position[-1]
        if x_start < lo or x_stop > hi:
            raise InputError(
                f"The run covers positions {x_start:g} to {x_stop:g} m but the profile is sampled only "
                f"from {lo:g} to {hi:g} m; shorten --duration, lower --speed or mark it periodic."
            )

    def describe(self) -> str:
        return f"sampled ({self.source}, {self.position.size} points{', periodic' if self.periodic else ''})"


@dataclass(frozen=True, eq=False)
class RandomRoughness(SurfaceProfile):
    """Band-limited random roughness: a sum of sines with random phases (spectral method).

    The wavenumbers are spread evenly in 1/lambda between ``1/wavelength_max`` and
    ``1/wavelength_min`` with a random jitter, the amplitudes are equal (flat spectrum in
    the band) and scaled so the profile's RMS is ``rms``; the phases are uniform. Draw one
    with :meth:`draw`, which takes the random generator, so every profile is reproducible.

    Attributes
    ----------
    wavenumber, amplitude, phase : ndarray, shape (n_components,)
        k [rad/m], a [m] and phi [rad] of q(x) = sum a sin(k x + phi).
    """

    wavenumber: Array
    amplitude: Array
    phase: Array
    kind = "random"

    @classmethod
    def draw(
        cls,
        *,
        rms: float,
        wavelength_min: float,
        wavelength_max: float,
        rng: np.random.Generator,
        n_components: int = 64,
    ) -> RandomRoughness:
        """Draw a roughness profile of RMS ``rms`` [m] in the band [wavelength_min, wavelength_max] [m].

        Parameters
        ----------
        rms : float
            RMS height [m], >= 0.
        wavelength_min, wavelength_max : float
            Shortest and longest wavelength [m], ``wavelength_min < wavelength_max``.
        rng : numpy.random.Generator
            Source of the wavenumber jitter and the phases.
        n_components : int, default 64
            Number of sines.

        Returns
        -------
        RandomRoughness

        Examples
        --------
        >>> p = RandomRoughness.draw(rms=1e-6, wavelength_min=0.2e-3, wavelength_max=2e-3,
        ...                          rng=np.random.default_rng(0))
        >>> q, _ = p.evaluate(np.linspace(0, 0.5, 200001))
        >>> bool(abs(q.std() / 1e-6 - 1) < 0.1)
        True
        """
        rms = validate_positive("rms", rms, allow_zero=True)
        lo = validate_positive("wavelength_min", wavelength_min)
        hi = validate_positive("wavelength_max", wavelength_max)
        if lo >= hi:
            raise InputError(f"Parameter wavelength_min={lo!r} must be < wavelength_max={hi!r}.")
        if not isinstance(rng, np.random.Generator):
            raise InputError("Parameter rng must be a numpy.random.Generator (numpy.random.default_rng(seed)).")
        n = int(n_components)
        if n < 1:
            raise InputError(f"Parameter n_components={n_components!r} must be >= 1.")
        edges = np.linspace(1.0 / hi, 1.0 / lo, n + 1)
        nu = edges[:-1] + rng.uniform(size=n) * np.diff(edges)
        a = np.full(n, rms * math.sqrt(2.0 / n))
        return cls(2 * math.pi * nu, a, rng.uniform(0.0, 2 * math.pi, size=n))

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:
        return _harmonics(x, self.wavenumber, self.amplitude, self.phase)

    def describe(self) -> str:
        rms = float(np.sqrt(0.5 * np.sum(self.amplitude**2)))
        lam = 2 * math.pi / self.wavenumber
        return f"random rms={rms:g} m lambda={lam.min():g}..{lam.max():g} m ({self.wavenumber.size} components)"


@dataclass(frozen=True, eq=False)
class DiscRunOut(SurfaceProfile):
    """Run-out of a rotating disc: repeats every revolution at the track radius.

    q(x) = sum_n a_n sin(n x / r + phi_n) over integer orders n (cycles per revolution),
    with ``x = r * angle`` the arc length along the track.

    Parameters
    ----------
    radius : float
        Track radius r [m]; one revolution is 2 pi r of sliding.
    order, amplitude, phase : array_like, shape (m,)
        Orders n (>= 1) [cycles/rev], amplitudes a_n [m] and phases phi_n [rad].

    Examples
    --------
    >>> disc = DiscRunOut.build(radius=0.1, macro={1: 20e-6, 2: 5e-6}, micro_rms=0.5e-6,
    ...                         micro_orders=(40, 200), rng=np.random.default_rng(1))
    >>> round(disc.sliding_speed(900.0), 3)            # 900 rpm at r = 0.1 m  [m/s]
    9.425
    """

    radius: float
    order: Array
    amplitude: Array
    phase: Array
    kind = "disc"

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", validate_positive("radius", self.radius))
        order = validate_array_finite("order", self.order).ravel()
        amp = validate_array_finite("amplitude", self.amplitude).ravel()
        ph = validate_array_finite("phase", self.phase).ravel()
        if not (order.shape == amp.shape == ph.shape):
            raise InputError("DiscRunOut needs order, amplitude and phase of equal length.")
        if np.any(order < 1) or np.any(order != np.round(order)):
            raise InputError("DiscRunOut orders must be whole numbers >= 1 (cycles per revolution).")
        object.__setattr__(self, "order", order)
        object.__setattr__(self, "amplitude", amp)
        object.__setattr__(self, "phase", ph)

    @classmethod
    def build(
        cls,
        *,
        radius: float,
        macro: dict[int, float] | None = None,
        micro_rms: float = 0.0,
        micro_orders: tuple[int, int] = (30, 300),
        rng: np.random.Generator | None = None,
    ) -> DiscRunOut:
        """Macro run-out ``{order: amplitude [m]}`` (zero phase) plus random micro run-out.

        The micro part has RMS ``micro_rms`` [m] spread evenly over the orders in
        ``micro_orders`` (inclusive) with random phases drawn from ``rng``.

        Parameters
        ----------
        radius : float
            Track radius [m].
        macro : dict of int to float, optional
            Amplitude [m] of each macro order (cycles per revolution).
        micro_rms : float, default 0.0
            RMS [m] of the micro run-out.
        micro_orders : (int, int), default (30, 300)
            First and last micro order.
        rng : numpy.random.Generator, optional
            Source of the micro phases (required when ``micro_rms > 0``).

        Returns
        -------
        DiscRunOut
        """
        orders, amps, phases = [], [], []
        for n, a in (macro or {}).items():
            orders.append(float(n))
            amps.append(validate_positive(f"macro amplitude of order {n}", a, allow_zero=True))
            phases.append(0.0)
        micro_rms = validate_positive("micro_rms", micro_rms, allow_zero=True)
        if micro_rms > 0:
            if not isinstance(rng, np.random.Generator):
                raise InputError("Micro run-out needs rng, a numpy.random.Generator.")
            lo, hi = int(micro_orders[0]), int(micro_orders[1])
            if not 1 <= lo <= hi:
                raise InputError(f"Parameter micro_orders={micro_orders!r} must satisfy 1 <= low <= high.")
            n = np.arange(lo, hi + 1, dtype=float)
            orders += n.tolist()
            amps += [micro_rms * math.sqrt(2.0 / n.size)] * n.size
            phases += rng.uniform(0.0, 2 * math.pi, size=n.size).tolist()
        if not orders:
            raise InputError("DiscRunOut needs macro orders or micro_rms > 0.")
        return cls(radius, np.array(orders), np.array(amps), np.array(phases))

    def sliding_speed(self, rpm: float) -> float:
        """Sliding speed v = 2 pi r rpm / 60 [m/s] at the track radius.

        Parameters
        ----------
        rpm : float
            Disc speed [rev/min].

        Returns
        -------
        float
        """
        return 2 * math.pi * self.radius * validate_positive("rpm", rpm) / 60.0

    def evaluate(self, x: ArrayLike) -> tuple[Array, Array]:
        return _harmonics(x, self.order / self.radius, self.amplitude, self.phase)

    def describe(self) -> str:
        return f"disc r={self.radius:g} m, {self.order.size} orders up to {int(self.order.max())}/rev"
