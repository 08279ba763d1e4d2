"""Parameters of the packing preparation protocol (docs/method.md §3).

They live with every other stage's parameters in :mod:`granwave.params`; this
module keeps the historical import path.
"""

from ..params import MAX_SAFETY, PrepareParams  # noqa: F401
