"""The registry of contact sub-models: one line per sub-model (its module in this package).

Within a kind (granwave.contact_models.kinds) the order gives the codes the kernels branch on, so
add a new sub-model at the end (a kind without an off name registers its default first: code 0).
After a change here, or in a sub-model's declarations, run
``python -m granwave.contact_models.generate`` (it rewrites the generated ``_table.py`` and
``_dispatch.py``; tests/test_contact_registry.py checks they are current).
"""

SUBMODELS = (
    "hertz",
    "harmonic",
    "rolling",
    "damping_critical",
    "mindlin",
    "linear_history",
    "damping_viscous",
    "cone",
    "cone_hertz",
)
