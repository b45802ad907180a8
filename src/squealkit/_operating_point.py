"""The paper's operating points the report works at: one place below the report and the warm-up.

The report's steps (:mod:`squealkit.report`) run their analyses at these values, and the warm-up
child (:mod:`squealkit._warmup`) compiles the kernels those steps will need for the same values,
so that it compiles the report's types. This module imports nothing, so the warm-up reads them
without importing the report, whose runner starts and waits for it.
"""

__all__ = ["CYCLE_HARMONICS", "CYCLE_MU_RANGE", "RIG_FS", "RIG_RADIUS", "RIG_RPM", "RIG_SQUEAL_FREQ", "SPEED"]

#: Sliding speed v [m/s] (paper §4), the report's default.
SPEED = 0.02

#: The paper's §5 rig: disc speed [rev/min], sample rate [Hz] and probe radius [m] (not given in the
#: paper; 50 mm assumed). 10 N; the paper's squeal main frequency is about 2388 Hz.
RIG_RPM, RIG_FS, RIG_RADIUS = 900.0, 40_000.0, 0.05
#: The squeal's main frequency the paper reports for its rig [Hz] (§5).
RIG_SQUEAL_FREQ = 2388.0

#: Friction range of the report's flat-disc limit-cycle branch, and the harmonics of every cycle.
CYCLE_MU_RANGE, CYCLE_HARMONICS = (0.3, 1.0), 10
