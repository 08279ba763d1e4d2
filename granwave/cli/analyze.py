"""``granwave analyze ...``: the analysis subcommands (each in its own module)."""

import click

from . import LazyGroup

ANALYSES = {
    "statics": "granwave.cli.analyze_statics:statics",
    "front": "granwave.cli.analyze_front:front",
    "moduli": "granwave.cli.analyze_moduli:moduli",
    "heights": "granwave.cli.analyze_heights:heights",
    "ensemble": "granwave.cli.analyze_ensemble:ensemble",
    "spectrum": "granwave.cli.analyze_spectrum:spectrum",
    "damping": "granwave.cli.analyze_damping:damping",
    "continuum": "granwave.cli.analyze_continuum:continuum",
    "attenuation": "granwave.cli.analyze_attenuation:attenuation",
    "shocks": "granwave.cli.analyze_shocks:shocks",
}


@click.group(cls=LazyGroup, lazy_commands=ANALYSES)
def analyze():
    """Measure packings, signals and spectra (docs/method.md §4, §6, §7, §9)."""
