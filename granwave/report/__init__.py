"""The study's report (results/report/index.md and index.html).

| module | job |
|---|---|
| :mod:`.inputs` | read JSON files and folders, scenes, the config, figures |
| :mod:`.references` | the chain's exact γ, δ and front features (theory) |
| :mod:`.numbers` | the one rule for numbers: value ± error, counts, ranges, bounds |
| :mod:`.findings` | the first page: what was run, one row per headline result against its reference |
| :mod:`.validated` | what an estimator is worth: its bias and coverage from the truth suite |
| :mod:`.symbols` | every symbol of the page and the figures, once, with its unit |
| :mod:`.tables` | cells and one table builder per section (rules in its docstring) |
| :mod:`.continuum` | the continuum scenes' section (speeds against L, c_tof/c_ℓ, α(ω), c(ω)) |
| :mod:`.shear` | the shear scenes' section (V_s, V_p, G_max against p, Poisson ratios, pick table) |
| :mod:`.html` | the HTML twin, rendered by the `markdown` package |
| :mod:`.index` | the page: :func:`build_report`, :func:`write_report` |
"""

from .html import markdown_to_html
from .index import build_report, write_report
from .inputs import (collect_json, find_figures, heights_arrays, heights_means, label_from_path,
                     load_config, sweep_speeds)
from .references import chain_exact_exponents, chain_series
from .numbers import fmt_range
from .tables import fmt

__all__ = ["build_report", "chain_exact_exponents", "chain_series", "collect_json", "find_figures",
           "fmt", "fmt_range", "heights_arrays", "heights_means", "label_from_path", "load_config",
           "markdown_to_html", "sweep_speeds", "write_report"]
