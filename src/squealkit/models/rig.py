"""Model parameters from a rig: geometry, materials and modal frequencies (paper §3, §5.1).

The paper derives each stiffness of its model from a modal frequency,
``k = m (2 pi f)^2``, the pin mass from its geometry and density, and the contact
stiffness from the pin's axial stiffness ``E A / L``. The pin's own frequencies come from
FEA in the paper (Table 1); here they can also come from beam theory: Euler-Bernoulli, or
Timoshenko (shear and rotary inertia), which matters for the paper's stubby pin
(L/d = 1.5).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any, Literal

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq

from .._validation import InputError, validate_positive
from ._base import declared_value, param, parameter_info
from .pin_on_disc import PinOnDisc3DOF

__all__ = [
    "CANTILEVER_TIP_MASS_FACTOR",
    "PinOnDiscRig",
    "RigModel",
    "cantilever_bending_frequency",
    "contact_stiffness",
    "modal_stiffness",
    "rod_axial_frequency",
    "rod_mass",
]

#: First root of 1 + cos(b) cosh(b) = 0, the clamped-free Euler-Bernoulli beam.
_BETA1_CLAMPED_FREE = 1.8751040687119611


def modal_stiffness(mass: float, freq: float) -> float:
    """Modal stiffness ``k = m (2 pi f)^2`` [N/m] of a mode of frequency ``freq`` [Hz].

    Parameters
    ----------
    mass : float
        Modal mass of the mode [kg], > 0.
    freq : float
        Its natural frequency [Hz], > 0.

    Returns
    -------
    float
        The modal stiffness [N/m].

    Raises
    ------
    InputError
        If ``mass`` or ``freq`` is not a positive finite number.

    Examples
    --------
    >>> round(modal_stiffness(0.033, 2561.0) / 1e6, 3)   # paper §3: k1 = 8.545e6 N/m
    8.545
    """
    m = validate_positive("mass", mass)
    f = validate_positive("freq", freq)
    return m * (2.0 * math.pi * f) ** 2


def rod_mass(diameter: float, length: float, density: float) -> float:
    """Mass ``rho pi d^2 / 4 L`` [kg] of a round rod.

    Parameters
    ----------
    diameter, length : float
        Rod diameter and length [m], > 0.
    density : float
        Material density [kg/m^3], > 0.

    Returns
    -------
    float
        The rod's mass [kg].

    Examples
    --------
    >>> round(rod_mass(0.03, 0.045, 1040) * 1e3, 2)   # the paper's PA6 pin [g]
    33.08
    """
    d = validate_positive("diameter", diameter)
    L = validate_positive("length", length)
    rho = validate_positive("density", density)
    return rho * math.pi * d * d / 4.0 * L


def contact_stiffness(diameter: float, length: float, youngs_modulus: float) -> float:
    """Axial stiffness ``E A / L`` [N/m] of a round rod, the paper's contact stiffness kc.

    Parameters
    ----------
    diameter, length : float
        Rod diameter and length [m], > 0.
    youngs_modulus : float
        Young's modulus E [Pa], > 0.

    Returns
    -------
    float
        The axial stiffness [N/m].

    Examples
    --------
    >>> round(contact_stiffness(0.03, 0.045, 2.95e9) / 1e7, 3)   # paper §3: kc = 4.632e7 N/m
    4.634
    """
    d = validate_positive("diameter", diameter)
    L = validate_positive("length", length)
    E = validate_positive("youngs_modulus", youngs_modulus)
    return E * math.pi * d * d / 4.0 / L


def rod_axial_frequency(length: float, youngs_modulus: float, density: float) -> float:
    """First axial frequency of a clamped-free rod, ``sqrt(E / rho) / (4 L)`` [Hz].

    Parameters
    ----------
    length : float
        Free length of the rod [m], > 0.
    youngs_modulus : float
        Young's modulus E [Pa], > 0.
    density : float
        Material density [kg/m^3], > 0.

    Returns
    -------
    float
        The quarter-wave frequency [Hz].
    """
    L = validate_positive("length", length)
    E = validate_positive("youngs_modulus", youngs_modulus)
    rho = validate_positive("density", density)
    return math.sqrt(E / rho) / (4.0 * L)


def _timoshenko_determinant(omega: float, d: float, L: float, E: float, rho: float, nu: float) -> float:
    """Clamped-free boundary determinant of a Timoshenko beam at circular frequency omega."""
    A = math.pi * d * d / 4.0
    I = math.pi * d**4 / 64.0  # noqa: E741
    G = E / (2.0 * (1.0 + nu))
    kappa = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)  # Cowper's shear coefficient, solid circle
    kGA = kappa * G * A
    # State z = [w, w', psi, psi']: kGA (w'' - psi') + rho A w omega^2 = 0,
    # E I psi'' + kGA (w' - psi) + rho I omega^2 psi = 0.
    Amat = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-rho * A * omega**2 / kGA, 0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0, 1.0],
            [0.0, -kGA / (E * I), kGA / (E * I) - rho * I * omega**2 / (E * I), 0.0],
        ]
    )
    # Scale x by L so expm sees O(1) entries.
    Phi = expm(Amat * L)
    # Clamped at 0: w = psi = 0, so z(0) = a e2 + b e4. Free at L: psi' = 0, w' - psi = 0.
    cols = Phi[:, [1, 3]]
    rows = np.vstack([cols[3], cols[1] - cols[2]])
    return float(np.linalg.det(rows))


def cantilever_bending_frequency(
    diameter: float,
    length: float,
    youngs_modulus: float,
    density: float,
    *,
    poisson: float = 0.35,
    theory: Literal["euler_bernoulli", "timoshenko"] = "timoshenko",
) -> float:
    """First bending frequency [Hz] of a clamped-free round rod.

    Parameters
    ----------
    diameter, length : float
        Rod diameter and free length [m].
    youngs_modulus, density : float
        E [Pa] and rho [kg/m^3].
    poisson : float
        Poisson's ratio (Timoshenko only: shear modulus and Cowper's shear coefficient).
    theory : {"timoshenko", "euler_bernoulli"}
        Beam theory. Euler-Bernoulli overestimates stubby rods.

    Returns
    -------
    float
        The first bending frequency [Hz].

    Examples
    --------
    The paper's PA6 pin (d = 30 mm, L = 45 mm, E = 2.95 GPa, rho = 1040 kg/m^3) against
    its FEA value of 2561 Hz (Table 1):

    >>> round(cantilever_bending_frequency(0.03, 0.045, 2.95e9, 1040, theory="euler_bernoulli"))
    3491
    """
    d = validate_positive("diameter", diameter)
    L = validate_positive("length", length)
    E = validate_positive("youngs_modulus", youngs_modulus)
    rho = validate_positive("density", density)
    if not (-1.0 < poisson < 0.5):
        raise InputError(f"Parameter poisson={poisson!r} must lie in (-1, 0.5).")
    A = math.pi * d * d / 4.0
    I = math.pi * d**4 / 64.0  # noqa: E741
    omega_eb = _BETA1_CLAMPED_FREE**2 * math.sqrt(E * I / (rho * A * L**4))
    if theory == "euler_bernoulli":
        return omega_eb / (2.0 * math.pi)
    if theory != "timoshenko":
        raise InputError(f"Parameter theory={theory!r} must be 'timoshenko' or 'euler_bernoulli'.")
    # Shear and rotary inertia only lower the first frequency: bracket below omega_eb.
    def f(w: float) -> float:
        return _timoshenko_determinant(w, d, L, E, rho, poisson)

    grid = np.linspace(0.05, 1.0, 96) * omega_eb
    vals = [f(w) for w in grid]
    for lo, hi, flo, fhi in zip(grid[:-1], grid[1:], vals[:-1], vals[1:], strict=True):
        if flo == 0.0:
            return lo / (2.0 * math.pi)
        if flo * fhi < 0.0:
            return brentq(f, lo, hi, xtol=1e-10, rtol=1e-13) / (2.0 * math.pi)
    raise InputError("No Timoshenko bending mode found below the Euler-Bernoulli frequency.")


#: What a pin frequency left out (or named) in a rig comes from.
_BENDING_THEORIES = {"timoshenko": "Timoshenko beam theory (shear, rotary inertia)",
                     "euler_bernoulli": "Euler-Bernoulli beam theory"}
_AXIAL_THEORIES = {"rod": "quarter-wave clamped-free rod theory"}
#: The paper's FEA frequencies of the pin (Table 1) [Hz].
PAPER_PIN_FREQ_HZ = {"bending": 2561.0, "axial": 8653.0}
#: Tip modal mass of a clamped-free beam's first bending mode, as a share of its mass (mode shape
#: scaled to 1 at the tip); the paper uses the whole mass (factor 1).
CANTILEVER_TIP_MASS_FACTOR = 0.25


@dataclass(frozen=True)
class PinOnDiscRig:
    """A pin-on-disc rig described by what can be measured on it (paper §5.1).

    The paper's own rig, with its FEA pin frequencies, is :meth:`paper`. A pin frequency not
    given (``None``, or a theory's name) comes from beam theory: ``pin_bending_freq`` from
    Timoshenko theory (``"timoshenko"``, the default, or ``"euler_bernoulli"``),
    ``pin_axial_freq`` from the quarter-wave rod (``"rod"``). :meth:`frequency_sources`
    says where each frequency came from.

    The paper's derivation choices are the defaults, and each can be changed:

    - ``pin_mass_factor`` (default 1): the pin's modal mass as a share of its whole mass,
      ``m1 = factor rho A L`` and ``k = m1 (2 pi f)^2``. The paper takes the whole mass; a
      cantilever's first bending mode has a tip modal mass of about a quarter of it
      (:data:`CANTILEVER_TIP_MASS_FACTOR`). Frequencies are kept; the pin/disc mass ratio and
      the contact stiffness relative to k1, k2 change.
    - ``preload`` (default ``"pin_load"``): ``P`` is the load on the pin, as in the paper
      (it acts on m1 while k2 is grounded, so the static contact force is only about 3 N of
      the paper's 10 N); ``"contact_force"`` makes ``P`` the static contact force.
    - ``kc = E A / L``, the pin's own axial stiffness (the paper's choice; k2 models the
      same pin's axial mode, so the pin's axial compliance is counted twice).

    Parameters
    ----------
    pin_diameter, pin_length : float, default 0.030, 0.045
        Diameter and free length of the round pin [m] (paper §3: 30 mm by 45 mm).
    pin_youngs_modulus : float, default 2.95e9
        Young's modulus of the pin [Pa] (PA6).
    pin_density : float, default 1040.0
        Density of the pin [kg/m^3].
    pin_poisson : float, default 0.35
        Poisson's ratio of the pin (Timoshenko theory only), in (-1, 0.5).
    disc_mass : float, default 4.35
        Modal mass of the disc's out-of-plane mode [kg].
    disc_freq : float, default 2346.0
        Frequency of that disc mode [Hz] (paper Table 1).
    pin_bending_freq : float or {"timoshenko", "euler_bernoulli"} or None, default None
        Pin bending frequency [Hz]; ``None`` or a theory's name computes it from beam theory
        (``None`` uses ``pin_bending_theory``).
    pin_axial_freq : float or {"rod"} or None, default None
        Pin axial (tensile) frequency [Hz]; ``None`` or ``"rod"`` uses the quarter-wave rod.
    pin_bending_theory : {"timoshenko", "euler_bernoulli"}, default "timoshenko"
        Beam theory used when ``pin_bending_freq`` is ``None``.
    alpha : float, default radians(2)
        Incline of the pin spring k2 from the vertical [rad] (paper: 2 deg).
    P : float, default 10.0
        Axial load [N], >= 0; its meaning is set by ``preload``.
    c1, c2, c3 : float, default 220.0
        Dampers beside k1, k2, k3 [N s/m], >= 0 (paper §4).
    sliding : {-1, +1}, default -1
        Sliding direction, as in :class:`PinOnDisc3DOF` (the paper's Fig. 2 needs -1).
    pin_mass_factor : float, default 1.0
        Pin modal mass as a share of the whole pin mass, in (0, 1].
    preload : {"pin_load", "contact_force"}, default "pin_load"
        Whether ``P`` is the load on the pin (the paper) or the static contact force.

    Raises
    ------
    InputError
        If a value is out of its range or a theory's name is unknown.

    Examples
    --------
    >>> rig = PinOnDiscRig.paper()
    >>> round(rig.to_model().kc / 1e7, 3)   # paper §3: kc = 4.632e7 N/m
    4.634
    >>> round(PinOnDiscRig().bending_freq(), 1)   # the same pin from Timoshenko theory
    2855.9
    """

    pin_diameter: float = param(0.030, unit="m", doc="diameter of the round pin", plausible=(1e-3, 0.2))
    pin_length: float = param(0.045, unit="m", doc="free length of the pin", plausible=(1e-3, 0.5))
    pin_youngs_modulus: float = param(2.95e9, unit="Pa", doc="Young's modulus of the pin", plausible=(1e7, 1.5e12))
    pin_density: float = param(1040.0, unit="kg/m^3", doc="density of the pin", plausible=(100.0, 25e3))
    pin_poisson: float = param(0.35, unit="1", doc="Poisson's ratio of the pin", kind="finite")
    disc_mass: float = param(4.35, unit="kg", doc="modal mass of the disc's out-of-plane mode",
                             plausible=(1e-3, 500.0))
    disc_freq: float = param(2346.0, unit="Hz", doc="frequency of that disc mode", plausible=(20.0, 50e3))
    pin_bending_freq: float | str | None = param(None, unit="Hz", doc="pin bending frequency (None: beam theory)",
                                                 plausible=(20.0, 100e3))
    pin_axial_freq: float | str | None = param(None, unit="Hz", doc="pin axial frequency (None: quarter-wave rod)",
                                               plausible=(20.0, 100e3))
    pin_bending_theory: Literal["euler_bernoulli", "timoshenko"] = param(
        "timoshenko", unit="", doc="beam theory of a pin bending frequency not given", kind="choice",
        choices=tuple(_BENDING_THEORIES))
    alpha: float = param(math.radians(2.0), unit="rad", doc="incline of the pin spring k2", kind="angle",
                         plausible=(0.0, 0.8))
    P: float = param(10.0, unit="N", doc="axial load (its meaning set by preload)", kind="nonnegative")
    c1: float = param(220.0, unit="N s/m", doc="damper beside k1", kind="nonnegative")
    c2: float = param(220.0, unit="N s/m", doc="damper beside k2", kind="nonnegative")
    c3: float = param(220.0, unit="N s/m", doc="damper beside k3", kind="nonnegative")
    sliding: int = param(-1, unit="1", doc="sliding direction", kind="sign")
    pin_mass_factor: float = param(1.0, unit="1", doc="pin modal mass as a share of the pin mass")
    preload: Literal["pin_load", "contact_force"] = param(
        "pin_load", unit="", doc="what P is", kind="choice", choices=("pin_load", "contact_force"))
    _derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for f in fields(self):  # text with a unit ("25 mm", "2.9 kHz") in the declared unit; unit slips refused
            v = getattr(self, f.name)
            theory_name = f.name in ("pin_bending_freq", "pin_axial_freq") and isinstance(v, str) and not any(
                ch.isdigit() for ch in v)  # a theory's name, checked below
            if not theory_name:
                object.__setattr__(self, f.name, declared_value(f, v, what="the rig's "))
        skip = ("pin_bending_theory", "sliding", "alpha", "pin_poisson", "preload", "pin_bending_freq",
                "pin_axial_freq")
        for f in fields(self):
            if f.name.startswith("_") or f.name in skip:
                continue
            allow_zero = f.name in ("P", "c1", "c2", "c3")
            validate_positive(f.name, getattr(self, f.name), allow_zero=allow_zero)
        for name, theories in (("pin_bending_freq", _BENDING_THEORIES), ("pin_axial_freq", _AXIAL_THEORIES)):
            v = getattr(self, name)
            if isinstance(v, str):
                if v not in theories:
                    accepted = ", ".join(repr(t) for t in theories)
                    raise InputError(f"Parameter {name}={v!r} must be a frequency [Hz], omitted, or one of {accepted}.")
            elif v is not None:
                validate_positive(name, v)
        if self.pin_bending_theory not in _BENDING_THEORIES:
            raise InputError(f"Parameter pin_bending_theory={self.pin_bending_theory!r} must be 'timoshenko' or "
                             "'euler_bernoulli'.")
        if not self.pin_mass_factor <= 1.0:
            raise InputError(f"Parameter pin_mass_factor={self.pin_mass_factor!r} must lie in (0, 1].")
        if self.preload not in ("pin_load", "contact_force"):
            raise InputError(f"Parameter preload={self.preload!r} must be 'pin_load' or 'contact_force'.")

    #: What the rig's parameters are called in reports.
    kind = "pin_on_disc_rig"

    @classmethod
    def parameter_info(cls) -> dict[str, dict[str, str]]:
        """Each parameter's unit, meaning and kind, in declaration order (as a model's)."""
        return parameter_info(cls)

    @classmethod
    def paper(cls, **changes) -> PinOnDiscRig:
        """The paper's rig: the defaults with the FEA pin frequencies of Table 1 (2561 Hz, 8653 Hz)."""
        kw = {"pin_bending_freq": PAPER_PIN_FREQ_HZ["bending"], "pin_axial_freq": PAPER_PIN_FREQ_HZ["axial"]}
        return cls(**{**kw, **changes})

    def pin_mass(self) -> float:
        """Pin mass [kg] from geometry and density (the whole rod)."""
        return rod_mass(self.pin_diameter, self.pin_length, self.pin_density)

    def _bending_theory(self) -> str | None:
        v = self.pin_bending_freq
        return v if isinstance(v, str) else (self.pin_bending_theory if v is None else None)

    def bending_freq(self) -> float:
        """Pin bending frequency [Hz]: the given one, else beam theory."""
        theory = self._bending_theory()
        if theory is None:
            return float(self.pin_bending_freq)  # type: ignore[arg-type]
        return cantilever_bending_frequency(
            self.pin_diameter, self.pin_length, self.pin_youngs_modulus, self.pin_density,
            poisson=self.pin_poisson, theory=theory,  # type: ignore[arg-type]
        )

    def axial_freq(self) -> float:
        """Pin axial (tensile) frequency [Hz]: the given one, else the quarter-wave rod."""
        if self.pin_axial_freq is None or isinstance(self.pin_axial_freq, str):
            return rod_axial_frequency(self.pin_length, self.pin_youngs_modulus, self.pin_density)
        return float(self.pin_axial_freq)

    def frequency_sources(self) -> dict[str, dict[str, float | str]]:
        """Each modal frequency [Hz] the model is built from, and where it came from.

        Examples
        --------
        >>> PinOnDiscRig(pin_axial_freq=8653.0).frequency_sources()["pin_bending"]["source"]
        'Timoshenko beam theory (shear, rotary inertia)'
        """
        theory = self._bending_theory()
        axial_given = self.pin_axial_freq is not None and not isinstance(self.pin_axial_freq, str)
        return {
            "pin_bending": {"frequency_hz": self.bending_freq(),
                            "source": "given" if theory is None else _BENDING_THEORIES[theory]},
            "pin_axial": {"frequency_hz": self.axial_freq(),
                          "source": "given" if axial_given else _AXIAL_THEORIES["rod"]},
            "disc": {"frequency_hz": float(self.disc_freq), "source": "given"},
        }

    def describe(self) -> str:
        """One line: each frequency and its source, e.g. for a CLI note or a report."""
        return "; ".join(f"{name.replace('_', ' ')} {v['frequency_hz']:.1f} Hz ({v['source']})"
                         for name, v in self.frequency_sources().items())

    def to_model(self, **changes: Any) -> PinOnDisc3DOF:
        """The 3-DOF model (paper eq. 4) with every stiffness derived from this rig.

        Parameters
        ----------
        **changes
            Model parameters changed before a ``preload = "contact_force"`` is scaled (as
            :meth:`FrictionModel.replace`), so that the static contact force is ``P`` for the
            model returned.

        Returns
        -------
        PinOnDisc3DOF
        """
        m1 = self.pin_mass_factor * self.pin_mass()
        model = PinOnDisc3DOF(
            m1=m1,
            m2=self.disc_mass,
            k1=modal_stiffness(m1, self.bending_freq()),
            k2=modal_stiffness(m1, self.axial_freq()),
            k3=modal_stiffness(self.disc_mass, self.disc_freq),
            kc=contact_stiffness(self.pin_diameter, self.pin_length, self.pin_youngs_modulus),
            c1=self.c1, c2=self.c2, c3=self.c3, alpha=self.alpha, P=self.P, sliding=self.sliding,
        )
        if changes:
            model = model.replace(**changes)
        if self.preload == "contact_force" and self.P > 0:
            # the static contact force is linear in P: scale P so that it equals the requested force
            per_newton = float(model.replace(P=1.0).static_contact_force(0.0))
            model = model.replace(P=self.P / per_newton)
        return model


@dataclass(frozen=True)
class RigModel:
    """A rig and the model parameters changed after its derivation: a model file with a [rig] table.

    ``to_model()`` is the model every command builds from the file; ``to_model(**changes)`` the
    same with some rig quantities (``disc_freq``, ``pin_diameter``, ...) or model parameters
    changed, derived anew (for a Monte Carlo over what a rig engineer measures).

    Parameters
    ----------
    rig : PinOnDiscRig
        The rig (with the file's ``P``, ``alpha``, dampers and ``sliding``).
    changes : mapping, optional
        Parameters of the derived model set after the derivation (e.g. ``kinematics``).

    Examples
    --------
    >>> rm = RigModel(PinOnDiscRig.paper())
    >>> round(rm.to_model(disc_freq=2400.0).k3 / rm.to_model().k3, 4)   # k3 = m2 (2 pi f)^2
    1.0466
    """

    rig: PinOnDiscRig
    changes: Mapping[str, Any] = field(default_factory=dict)

    kind = "pin_on_disc_rig"

    def parameter_info(self) -> dict[str, dict[str, str]]:
        """The rig's parameters, then the model's that the rig does not have."""
        rig = self.rig.parameter_info()
        return {**rig, **{k: v for k, v in PinOnDisc3DOF.parameter_info().items() if k not in rig}}

    def to_model(self, **changes: Any) -> PinOnDisc3DOF:
        """The derived model, with ``changes`` (rig quantities or model parameters) applied."""
        rig_fields = self.rig.parameter_info()
        to_rig = {k: v for k, v in changes.items() if k in rig_fields}
        rig = dataclasses.replace(self.rig, **to_rig) if to_rig else self.rig
        return rig.to_model(**{**self.changes, **{k: v for k, v in changes.items() if k not in to_rig}})
