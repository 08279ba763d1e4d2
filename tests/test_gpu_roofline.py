"""The GPU step's memory-traffic model (granwave.gpu.roofline): the history columns of a
contact count (rolling resistance adds columns that every step reads and writes)."""

from granwave.contact_models.models import history_columns
from granwave.contact_models.options import defaults
from granwave.gpu.roofline import bytes_per_step


def test_default_history_is_the_tangential_force():
    for dim in (2, 3):
        assert bytes_per_step(1000, 2000, dim, 1) == bytes_per_step(1000, 2000, dim, 1, history=dim)


def test_rolling_columns_add_their_reads_and_writes():
    n, npairs = 1000, 2000
    for dim in (2, 3):
        plain = history_columns(dim, defaults())
        rolling = history_columns(dim, {**defaults(), "rolling": "sds"})
        assert rolling > plain == dim
        extra = bytes_per_step(n, npairs, dim, 1, rolling) - bytes_per_step(n, npairs, dim, 1, plain)
        # each extra 8-byte column: read and written once per pair, and per grain for its two
        # wall slots
        assert extra == 8 * (rolling - plain) * (2 * npairs + 4 * n)
