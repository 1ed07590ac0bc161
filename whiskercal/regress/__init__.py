"""Regression of every pipeline stage on the recorded datasets in data/.

``regress(data_dir)`` recomputes the fit, the lookup, the study report and the runtime's view of
the target from each recorded dataset, and fit's default path beside them (``default_fit``),
and compares them with the dataset's golden results, each quantity within the tolerance of its
class (whiskercal.regress.tolerances says why each bound). ``whiskercal regress`` is the command; ``pack.compact_copy`` makes recorded files small
enough for git.
"""

from whiskercal.regress.compare import Change, compare
from whiskercal.regress.golden import Dataset, find_datasets, read_golden
from whiskercal.regress.runner import DatasetResult, regress

__all__ = ["Change", "Dataset", "DatasetResult", "compare", "find_datasets", "read_golden",
           "regress"]
