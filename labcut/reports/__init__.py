"""Reports: comparisons of cuts (``labcut.compare_cuts``, ``labcut compare``).

A layer above rendering, orientation and plots (tests/test_layers.py): it combines
recommendations, flash metrics, renders and figures into a self-contained HTML page and
JSON/CSV tables (docs/compare.md).
"""

from .compare import Comparison, compare_cuts, naming_scenario, plan_comparison, run_comparison
from .cuts import Cut, parse_cab_spec, resolve_cuts
from .html import rank_label

__all__ = ["Comparison", "Cut", "compare_cuts", "naming_scenario", "parse_cab_spec", "plan_comparison", "rank_label",
           "resolve_cuts", "run_comparison"]
