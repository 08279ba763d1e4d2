"""The study's figures: one module per figure family, one function per figure.

Every function takes data objects (:class:`~granwave.model.Packing`,
:class:`~granwave.model.Signal`, :class:`~granwave.model.Modes`, the dicts the
analysis wrote) and an output path, draws one figure and saves it atomically
(:func:`granwave.io.files.atomic_file`) as PNG — plus a PDF beside it when
``pdf=True``. They return the list of files written. Figures compute no
statistics of their own: averages, fits and exponents come from
:mod:`granwave.analysis` (docs/figures.md).

| module | figures |
|---|---|
| :mod:`.statics` | force/stiffness networks, contact roses |
| :mod:`.fields` | the pulse (snapshots, E(y, t), low-pass front), mode shapes |
| :mod:`.signals` | signals and ensemble average, system comparison, coherent part |
| :mod:`.fronts` | arrival times, A(L) and W(L) with local exponents |
| :mod:`.pressure` | speeds against pressure |
| :mod:`.spectrum` | eigen-spectrum and weights |
| :mod:`.damping` | the damping series |
| :mod:`.chain` | the chain against the Airy shape |
| :mod:`.continuum` | the continuum scene: speeds, c_tof/c_l, A, W, alpha(omega), c(omega) against L |
| :mod:`.shear` | the shear scene: V_s, V_p, G_max against p, Poisson ratios, picks against L |
| :mod:`.shocks` | the shocks scene: V/c0 against eps/delta0, the crossover strain against p, opening and sliding contacts |
| :mod:`granwave.report.captions` | figure names and captions (the report's) |
"""

from .chain import chain_airy
from .continuum import continuum_panels
from .common import DPI, output_paths, save_figure
from .damping import damping_series
from .fields import displacement_snapshot, mode_shapes, select_modes
from .fronts import amplitude_width, arrival_times
from .pressure import speeds_vs_pressure
from .shear import shear_panels
from .shocks import shocks_panels
from ..report.captions import FIGURES, caption_for  # the captions are the report's; the names are the plot commands'
from .signals import coherent_heights, signal_comparison, signal_label, signals_overlay
from .spectrum import spectrum
from .statics import contact_angles, contact_roses, contact_segments, force_network

__all__ = ["DPI", "FIGURES", "amplitude_width", "arrival_times", "caption_for", "chain_airy",
           "coherent_heights", "contact_angles", "continuum_panels", "contact_roses", "contact_segments",
           "damping_series", "displacement_snapshot", "force_network", "mode_shapes",
           "output_paths", "save_figure", "select_modes", "shear_panels", "shocks_panels", "signal_comparison", "signal_label",
           "signals_overlay", "spectrum", "speeds_vs_pressure"]
