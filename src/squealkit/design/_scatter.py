"""The ``scatter`` argument of :func:`~squealkit.design.robust_margins`: its forms (the module notes of
:mod:`squealkit.design.robust`) turned into the distributions of :mod:`squealkit.uncertainty`, and their moments."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError, validate_finite
from ..uncertainty import DISTRIBUTIONS, UncertainParameter


def _scatter_table(scatter: Mapping[str, Any], nominal: Mapping[str, float]) -> dict[str, dict[str, Any]]:
    """The ``scatter`` entries in the table form of :mod:`squealkit.uncertainty` (module notes)."""
    if not isinstance(scatter, Mapping) or not scatter:
        raise InputError("Parameter scatter must be a non-empty mapping NAME -> coefficient of variation "
                         "(e.g. {'KR': 0.05}) or NAME -> {dist = ..., cov = ...}.")
    table: dict[str, dict[str, Any]] = {}
    for name, spec in scatter.items():
        if name not in nominal:
            continue  # the caller's name check says what is known
        if isinstance(spec, Mapping) and "cov" not in spec:
            table[name] = dict(spec)
            continue
        if isinstance(spec, Mapping):
            spec = dict(spec)
            dist = spec.pop("dist", "normal")
            cov = spec.pop("cov")
            if spec:
                raise InputError(f"Scatter of {name}: with cov= give only dist=, not {', '.join(sorted(spec))}.")
        else:
            dist, cov = "normal", spec
        if isinstance(cov, bool):
            raise InputError(f"Scatter of {name}: cov={cov!r} must be a number.")
        cov = validate_finite(f"scatter of {name} (cov)", cov)
        if not cov > 0:
            raise InputError(f"Scatter of {name}: the coefficient of variation cov={cov!r} must be > 0.")
        if dist not in DISTRIBUTIONS:
            raise InputError(f"Scatter of {name}: unknown dist={dist!r}; known: {', '.join(DISTRIBUTIONS)}.")
        p0 = float(nominal[name])
        if p0 == 0.0:
            raise InputError(f"Scatter of {name}: its nominal value is 0, so a coefficient of variation means "
                             "nothing; give the distribution itself (mean and std).")
        std = cov * abs(p0)
        if dist == "uniform":
            half = math.sqrt(3.0) * std  # a uniform's std is its half-width / sqrt(3)
            table[name] = {"dist": "uniform", "lower": p0 - half, "upper": p0 + half}
        else:
            table[name] = {"dist": dist, "mean": p0, "std": std}
    return table


def _uncertain(table: Mapping[str, Mapping[str, Any]]) -> tuple[UncertainParameter, ...]:
    out = []
    for name, spec in table.items():
        spec = dict(spec)
        dist = spec.pop("dist", None)
        if dist is None:
            raise InputError(f"Scatter of {name}: missing dist (one of {', '.join(DISTRIBUTIONS)}).")
        out.append(UncertainParameter(name, dist, spec))
    return tuple(out)


def _moments(unc: Sequence[UncertainParameter]) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Mean, standard deviation, third and fourth central moments of each parameter."""
    mean, std, m3, m4 = (np.empty(len(unc)) for _ in range(4))
    for j, p in enumerate(unc):
        m, v, skew, kurt = (float(x) for x in p.distribution.stats(moments="mvsk"))
        s = math.sqrt(v)
        mean[j], std[j], m3[j], m4[j] = m, s, skew * s**3, (kurt + 3.0) * s**4
    return mean, std, m3, m4
