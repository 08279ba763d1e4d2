"""The report's table of speed exponents per contact law (granwave.report.laws): each scene's law,
ν over its pressures and its halves, the law's own exponents, and p* by pressure-sweep --crossover's
estimator, from height series with a known answer."""

import math

import numpy as np
import pytest

from granwave.analysis.crossover import synthetic_series
from granwave.report.inputs import Scenes
from granwave.report.laws import law_exponent, laws_section

PRESSURES = np.logspace(-8, -3, 6)


def _series(p, c, e):
    return {float(a): {"pressure": float(a), "c_tof": float(b), "c_tof_err": float(s), "per_height": [],
                       "edge_heights": [8.0, 25.0]} for a, b, s in zip(p, c, e)}


def test_the_table_gives_each_law_s_exponents_and_p_star():
    config = {"lattices": {"lat_cone": {"friction": 0.0, "contact": {"contact_law": "cone", "cone_slope": 0.05}},
                           "lat_hertz": {"friction": 0.0}},
              "disordered": {"dis_x": {"friction": 0.5, "contact": {"contact_law": "cone_hertz",
                                                                    "crossover_overlap": 1e-3}}}}
    h = {"lat_cone": _series(PRESSURES, 0.05 * (PRESSURES / 1e-5) ** 0.25, 1e-6 * PRESSURES ** 0),
         "lat_hertz": _series(PRESSURES, 0.05 * (PRESSURES / 1e-5) ** (1 / 6), 1e-6 * PRESSURES ** 0),
         "dis_x": _series(*synthetic_series(5e-6, pressures=PRESSURES, noise=0.0, seed=0))}
    md = "\n".join(laws_section(h, Scenes(config)))
    rows = {line.split(" | ")[0].strip("| "): line.split(" | ") for line in md.splitlines()
            if line.startswith("| lat_") or line.startswith("| dis_")}
    assert set(rows) == {"lat_cone", "lat_hertz", "dis_x"}
    assert rows["lat_cone"][2] == "cone (cone_slope 0.05)" and rows["lat_hertz"][2] == "hertz"
    assert rows["dis_x"][2] == "cone_hertz (crossover_overlap 0.001)" and rows["dis_x"][1] == "disordered"
    def value(cell):
        return float(cell.split(" ")[0])
    assert value(rows["lat_cone"][4]) == pytest.approx(0.25, abs=1e-4)
    assert value(rows["lat_hertz"][4]) == pytest.approx(1 / 6, abs=1e-4)
    # the crossover series: its lower half at 1/4, its upper half at 1/6, p* at the truth
    assert value(rows["dis_x"][5]) == pytest.approx(0.25, abs=1e-4)
    assert value(rows["dis_x"][6]) == pytest.approx(1 / 6, abs=1e-4)
    assert value(rows["dis_x"][8]) == pytest.approx(5e-6, rel=1e-2)
    assert "not determined" in rows["lat_hertz"][8]
    # the laws' own exponents, from the lattice row chain of granwave.theory
    assert rows["lat_cone"][7] == "0.2500 / 0.2500" and rows["dis_x"][7].startswith("0.2500 / 0.1667")
    assert law_exponent(1e-8, {"contact_law": "cone_hertz"}, True) == pytest.approx(0.25, abs=1e-4)
    # fewer than 3 pressures: no row; no scene: no section
    short = {"lat_hertz": dict(list(h["lat_hertz"].items())[:2])}
    assert laws_section(short, Scenes(config)) == []
