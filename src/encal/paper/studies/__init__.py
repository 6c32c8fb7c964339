"""The paper's studies, each a function returning a result that tabulates and plots itself.

- :func:`hidden_node_sweep` (Fig. 2): training MSE against the number of hidden nodes and the epoch.
- :func:`compare_algorithms` (Table 2): final MSE per training algorithm, over seeds.
- :func:`svd_pruning` (Fig. 3): significant hidden nodes by SVD, and the retrained pruned network.
- :func:`compare_models` (Table 3, Fig. 4): Fourier, lookup-table and network models on the test grid.
- :func:`reproducibility`: repeat epochs and a second decoder against the first calibration.
- :mod:`~encal.paper.studies.tables`: the tables as text, CSV and HTML.

The network studies run their fits on up to two worker processes (``workers=``); every fit is seeded
by what it is, so results do not depend on the number of workers.
"""

from .algorithms import EXTRA_ALGORITHMS, PAPER_ALGORITHMS, AlgorithmStudy, compare_algorithms
from .comparison import DEFAULT_MODELS, PAPER_NETWORK, Comparison, ModelSpec, compare_models
from .pruning import PruningResult, significant_count, svd_pruning
from .reproducibility import Reproducibility, reproducibility
from .sweep import PAPER_HIDDEN, SweepResult, hidden_node_sweep
from .tables import Table

__all__ = [
    "hidden_node_sweep", "SweepResult", "PAPER_HIDDEN",
    "compare_algorithms", "AlgorithmStudy", "PAPER_ALGORITHMS", "EXTRA_ALGORITHMS",
    "svd_pruning", "PruningResult", "significant_count",
    "compare_models", "Comparison", "ModelSpec", "DEFAULT_MODELS", "PAPER_NETWORK",
    "reproducibility", "Reproducibility",
    "Table",
]
