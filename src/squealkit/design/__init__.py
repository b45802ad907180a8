"""Designing squeal out: derivatives of the unstable modes w.r.t. declared design parameters,
and the countermeasure study built on them.

- :mod:`~squealkit.design.parameters`: design parameters declared in the model file's ``[design]``
  table (a scale of a matrix part or of a node set, a point mass, a small model's parameter), each
  with its derivative matrices ``dM, dC, dK``;
- :mod:`~squealkit.design.derivatives`: ``d lambda / d p`` of every unstable mode from its right
  and left eigenvectors, for full and reduced FE models and small models;
- :mod:`~squealkit.design.countermeasures`: which change removes which mode (ranking, the smallest
  stabilising change confirmed by solves);
- :mod:`~squealkit.design.doe`: a design-of-experiments sweep on the reduced model, every reduced
  eigenpair checked by its backward error in the full model;
- :mod:`~squealkit.design.robust`: squeal propensity under parameter scatter, two estimates side by
  side: :mod:`~squealkit.design.montecarlo` (samples of the reduced model) and
  :mod:`~squealkit.design.perturbation` (the second-order perturbation estimate).
"""

from .countermeasures import COUNTERMEASURE_STATUS, countermeasures
from .derivatives import eigen_derivatives, eigenvalue_derivatives, left_eigenvectors
from .doe import doe_points, doe_sweep
from .parameters import DESIGN_PARTS, DesignParameter, design_parameters, load_design
from .robust import COUPLING_MAX, METHODS, PERTURBATION_STATUS, PerturbationWarning, robust_margins

__all__ = [
    "COUNTERMEASURE_STATUS",
    "COUPLING_MAX",
    "DESIGN_PARTS",
    "METHODS",
    "PERTURBATION_STATUS",
    "DesignParameter",
    "PerturbationWarning",
    "countermeasures",
    "design_parameters",
    "doe_points",
    "doe_sweep",
    "eigen_derivatives",
    "eigenvalue_derivatives",
    "left_eigenvectors",
    "load_design",
    "robust_margins",
]
