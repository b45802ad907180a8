"""Test meets model: a campaign's measured squeal against a model's predicted unstable modes.

The steps, each a module: :mod:`~squealkit.correlate.conditions` (a campaign's conditions ->
the model's operating points: friction from the matrix, a friction law or torque, disc
speed, parameter laws), :mod:`~squealkit.correlate.predict` (every unstable mode per
application, each distinct operating point solved once), :mod:`~squealkit.correlate.match`
(hit, miss, over-prediction, quiet; rates; noise matrices) and
:mod:`~squealkit.correlate.calibrate` (fit named quantities, with the interval the data
allow). :func:`correlate` runs them on a campaign folder.
"""

from .calibrate import Calibration, calibrate, parse_fit
from .conditions import (
    CONDITIONS,
    ConditionMap,
    FrictionLaw,
    ParameterLaw,
    campaign_conditions,
    condition_values,
    fit_friction_law,
    operating_points,
)
from .correlation import correlate, load_correlation_model
from .match import OUTCOMES, match_modes, measured_components
from .predict import apply_quantities, predict_modes

__all__ = ["CONDITIONS", "OUTCOMES", "Calibration", "ConditionMap", "FrictionLaw", "ParameterLaw",
           "apply_quantities", "calibrate", "campaign_conditions", "condition_values", "correlate",
           "fit_friction_law", "load_correlation_model", "match_modes", "measured_components", "operating_points",
           "parse_fit", "predict_modes"]
