"""Write the golden outputs of the measurement analysis and its figures (run once, before a refactor).

``analysis.npz``: every array and number of :func:`analyze_recording` on two synthetic recordings
(constant speed and a decelerating stop read from the tacho). ``figures.json``: a SHA-256 digest of the data every
artist of :func:`measurement_figures` draws (line vertices, image/mesh arrays), so a refactor of
where those arrays are computed can be checked bit for bit.

    PYTHONPATH=src python tests/golden_measurement/make_golden.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))

from _cases import analysis_arrays, cases, digest, figure_arrays  # noqa: E402

if __name__ == "__main__":
    an, figs = {}, {}
    for name, (rec, res, kw) in cases().items():
        an.update({f"{name}/{k}": v for k, v in analysis_arrays(res).items()})
        figs.update({f"{name}/{k}": v for k, v in figure_arrays(rec, res, kw).items()})
    np.savez_compressed(HERE / "analysis.npz", **an)
    (HERE / "figures.json").write_text(json.dumps({k: digest(v) for k, v in figs.items()}, indent=0,
                                                  sort_keys=True))
    print(len(an), "analysis arrays,", len(figs), "figure arrays")
