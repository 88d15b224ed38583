"""rliable's own numbers on hand-made data, for the tests of gdabench's aggregates (``tests/test_analysis.py``).

rliable 1.2.0 cannot be imported next to gdabench's pandas 3 (its ``arch < 8`` dependency fails to
import there, and ``arch`` 8 breaks rliable's bootstrap), so gdabench computes rliable's estimators
itself (:mod:`gdabench.report.aggregate`) and checks them against what rliable returns for fixed
inputs.  This script computes those values with rliable, in a venv of its own::

    python -m venv /tmp/venv-rliable && /tmp/venv-rliable/bin/pip install "rliable==1.2.0" "pandas<3" "arch<8"
    /tmp/venv-rliable/bin/python benchmarks/ops/rliable_reference.py > tests/expectations/rliable.json

Inputs (runs x tasks, already normalised): ``X`` and ``Y`` on 2 tasks, and ``A``/``B``/``C`` on 3 tasks
with ties and scores outside [0, 1] (as a random-normalised score can be).  Outputs: rliable's point
estimates (``metrics.aggregate_iqm``, ``metrics.probability_of_improvement``,
``library.score_distributions`` at ``TAUS``) and its 95% stratified-bootstrap percentile intervals
(``library.get_interval_estimates``, ``library.create_performance_profile``; ``reps`` resamples, 20,000
for the probability of improvement, after ``np.random.seed(0)``).  About 10 minutes of one core.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

X = [[0.1, 0.5], [0.4, 0.9], [0.4, 0.2], [0.8, 0.7], [0.6, 0.3], [0.2, 0.6]]
Y = [[0.3, 0.4], [0.1, 0.8], [0.5, 0.2], [0.7, 0.1], [0.2, 0.5], [0.4, 0.6]]
A = [[0.2, 1.1, -0.1], [0.5, 0.5, 0.3], [0.9, 0.7, 0.3], [0.1, 0.0, 0.6], [0.5, 0.9, 0.8]]
B = [[0.4, 0.2, 0.0], [0.5, 0.6, 0.3], [-0.2, 0.7, 0.5], [0.3, 0.1, 0.2], [0.8, 0.4, 0.3]]
C = [[0.0, 0.3, 0.1], [0.1, 0.3, 0.4], [0.6, 0.2, 0.0], [0.2, 0.2, 0.9], [0.3, 0.1, 0.3]]
TAUS = [0.0, 0.25, 0.5, 0.75, 1.0]
REPS = 50_000
#: the probability of improvement's bootstrap is 25 times slower in rliable (a Python loop per resample)
POI_REPS = 20_000


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()  # --help without rliable
    from rliable import library, metrics

    scores = {"X": np.array(X), "Y": np.array(Y), "A": np.array(A), "B": np.array(B), "C": np.array(C)}
    taus = np.array(TAUS)
    out: dict = {
        "reps": REPS,
        "poi_reps": POI_REPS,
        "taus": TAUS,
        "inputs": {k: v.tolist() for k, v in scores.items()},
        "designers": {},
    }
    for name, matrix in scores.items():
        np.random.seed(0)
        iqm = lambda x: np.array([metrics.aggregate_iqm(x)])  # noqa: E731
        _, ci = library.get_interval_estimates({name: matrix}, iqm, reps=REPS)
        np.random.seed(0)
        profile, profile_ci = library.create_performance_profile({name: matrix}, taus, reps=REPS)
        out["designers"][name] = {
            "iqm": float(metrics.aggregate_iqm(matrix)),
            "iqm_ci": [float(v) for v in ci[name][:, 0]],
            "profile": [float(v) for v in profile[name]],
            "profile_ci": [[float(v) for v in row] for row in profile_ci[name]],
        }
    out["improvement"] = {}
    for x, y in (("X", "Y"), ("A", "B"), ("C", "B")):
        pair = {f"{x},{y}": (scores[x], scores[y])}
        np.random.seed(0)
        point, ci = library.get_interval_estimates(pair, metrics.probability_of_improvement, reps=POI_REPS)
        out["improvement"][f"{x},{y}"] = {"probability": float(point[f"{x},{y}"]),
                                          "ci": [float(v) for v in ci[f"{x},{y}"][:, 0]]}  # fmt: skip
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
