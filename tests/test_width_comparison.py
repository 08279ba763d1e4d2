"""The report's comparison of continuum scenes of different widths (granwave.report.continuum
width_comparison): values interpolated between reliable frequencies and differences in combined
standard errors, on synthetic attenuation results with known answers."""

import math

import numpy as np

from granwave.report.continuum import _at, width_comparison


def _scene(cutoff, c_offset, band=(0.005, 0.02), pressure=1e-4):
    omega = np.linspace(0.0, 0.03, 31)
    reliable = (omega >= band[0] - 1e-12) & (omega <= band[1] + 1e-12)
    c = 0.19 + omega + c_offset  # linear in omega: interpolation is exact
    att = {"omega": omega.tolist(), "reliable": reliable.tolist(),
           "c": [float(v) if ok else None for v, ok in zip(c, reliable)],
           "c_err": [0.001 if ok else None for ok in reliable],
           "alpha": [1e-3 if ok else None for ok in reliable],
           "alpha_err": [1e-4 if ok else None for ok in reliable],
           "band": list(band), "omega_cutoff": cutoff}
    return {"front": {"pressure": pressure}, "attenuation": att}


def test_interpolation_between_reliable_frequencies_is_exact_for_a_line():
    att = _scene(0.02, 0.0)["attenuation"]
    value, error = _at(att, "c", 0.0123)
    assert math.isclose(value, 0.19 + 0.0123, rel_tol=1e-12) and math.isclose(error, 0.001)
    assert all(math.isnan(v) for v in _at(att, "c", 0.025))  # outside the reliable frequencies


def test_differences_in_combined_errors_against_the_widest_column():
    lines = width_comparison({"narrow": _scene(0.025, 0.002), "wide": _scene(0.0125, 0.0)},
                             {"narrow": 2, "wide": 2})
    rows = [r for r in lines if r.startswith("| 0.")]
    assert len(rows) == 5
    expected = f"{0.002 / (0.001 * math.sqrt(2)):+.1f}"  # +1.4
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        omega = float(cells[0])
        assert cells[1].endswith("†") == (omega > 0.0125)  # the wide column's cutoff
        assert not cells[2].endswith("†")  # the narrow column's cutoff is above the band
        assert cells[3] == expected and cells[6] == "+0.0"
    assert "against the widest column `wide`" in " ".join(lines)


def test_nothing_without_two_widths_at_one_pressure_and_dimension():
    two = {"a": 2, "b": 2}
    assert width_comparison({"a": _scene(0.0125, 0.0), "b": _scene(0.0125, 0.001)}, two) == []
    assert width_comparison({"a": _scene(0.0125, 0.0), "b": _scene(0.025, 0.0, pressure=1e-6)}, two) == []
    assert width_comparison({"a": _scene(0.0125, 0.0), "b": _scene(0.025, 0.0)}, {"a": 2, "b": 3}) == []
    assert width_comparison({"a": _scene(0.0125, 0.0), "b": _scene(0.025, 0.0)}, {"a": 2}) == []
    apart = width_comparison({"a": _scene(0.0125, 0.0, band=(0.005, 0.01)),
                              "b": _scene(0.025, 0.0, band=(0.012, 0.02))}, two)
    assert any("do not overlap" in line for line in apart)
