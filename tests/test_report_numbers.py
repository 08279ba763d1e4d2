"""The report's one rule for numbers (granwave.report.numbers): exact strings."""

from __future__ import annotations

import math

import pytest

from granwave.report.numbers import fmt, fmt_bound, fmt_count, fmt_positive, fmt_range, resolved


@pytest.mark.parametrize("x, err, text", [
    (4.099, 1.8, "4.1 ± 1.8"),            # leading 1: two digits of the error
    (0.8123, 0.021, "0.81 ± 0.02"),       # else one digit; the value rounded to match
    (0.9712, 0.005, "0.971 ± 0.005"),
    (0.2345, 0.0012, "0.2345 ± 0.0012"),
    (0.98, 0.16, "0.98 ± 0.16"),
    (0.96, 0.96, "1 ± 1"),                # rounding the error up to 1 keeps one digit
    (9.96, 0.0996, "9.96 ± 0.10"),        # 0.0996 rounds to 0.10: two digits
    (-93, 130, "-90 ± 130"),
    (371.4, 20.0, "370 ± 20"),
    (-0.3, 2.0, "0 ± 2"),                 # no "-0"
    (-0.00044, 0.00061, "(-4 ± 6)e-04"),  # small: one shared power of ten
    (0.0004, 0.00001, "(4.00 ± 0.10)e-04"),
    (123456.0, 789.0, "(1.235 ± 0.008)e+05"),
    (0.5, 1e-10, "0.5 ± 1e-10"),          # an error far below six digits: not padded
])
def test_value_and_error(x, err, text):
    assert fmt(x, err) == text


def test_value_without_error_and_missing():
    assert fmt(0.16666666) == "0.1667" and fmt(2.5, None) == "2.5" and fmt(1.0, 0.0) == "1"
    assert fmt(1.0, math.nan) == "1" and fmt(0.123456, digits=3) == "0.123"
    assert fmt(None) == fmt(math.nan) == fmt("x") == "—"


def test_counts_and_ranges():
    assert fmt_count(1168.0) == "1168" and fmt_count(3) == "3" and fmt_count(None) == "—"
    assert fmt_range(1168.0, 1172.0) == "1168 … 1172"          # integers as integers
    assert fmt_range(0.12341, 0.12345) == "0.1234 … 0.1235"    # digits enough to differ
    assert fmt_range(1e-7, 3e-7) == "1e-07 … 3e-07"


def test_bounds():
    assert fmt_bound(170.4) == "170" and fmt_bound(4.17) == "4.2" and fmt_bound(2.99) == "3.0"
    assert fmt_bound(3.73e7) == "3.7e+07" and fmt_bound(0.00078) == "7.8e-04"


@pytest.mark.parametrize("x, err, ci, text", [
    (0.5, 0.01, None, "0.500 ± 0.010"),                               # resolved
    (-0.00044, 0.00061, None, "< 7.8e-04 (95 %; consistent with 0)"),  # ± 2 errors reach 0
    (0.98, 0.16, (-1.03, 2.99), "< 3.0 (95 %; consistent with 0)"),   # the interval given
    (371.0, None, (4.17, 3.73e7), "[4.2, 3.7e+07] (95 %)"),          # over a decade
    (-1.0, 0.1, None, "not resolved (95 % interval ≤ 0)"),
    (-1.0, None, None, "not resolved (≤ 0)"),
    (2.0, None, None, "2"),                                            # no error: as it is
])
def test_positive_quantities(x, err, ci, text):
    assert fmt_positive(x, err, ci) == text


def test_named():
    from granwave.report.numbers import fmt_named

    assert fmt_named("α", "0.0070 ± 0.0007") == "α = 0.0070 ± 0.0007"
    assert fmt_named("α", "< 0.0025 (95 %; consistent with 0)") == "α < 0.0025 (95 %; consistent with 0)"
    assert fmt_named("α", "[1.6e-04, 0.0029] (95 %)") == "α ∈ [1.6e-04, 0.0029] (95 %)"


def test_positive_with_interval_and_resolved():
    assert fmt_positive(2.0, 0.1, (1.8, 2.2), show_ci=True) == "2.00 ± 0.10 (95 % 1.8 … 2.2)"
    assert resolved(1.0, 0.1) and not resolved(1.0, 0.6) and not resolved(1.0, None, (0.5, 6.0))


def test_continuum_section_shows_no_negative_attenuation_or_q():
    """α = −0.00044 ± 0.00061 and Q = −93 ± 130 (the default workflow's report) are bounds."""
    from granwave.report.continuum import approach_sentence, continuum_section

    att = {"omega": [0.1, 0.2], "alpha": [-0.00044, 0.002], "alpha_err": [0.00061, 0.0001],
           "Q": [-93.0, 250.0], "Q_err": [130.0, 13.0], "c": [0.5, 0.5], "c_err": [0.01, 0.01],
           "reliable": [True, True], "band": [0.1, 0.2], "heights": [8, 16, 32], "n_signals": 6,
           "threshold": 0.1, "c0": 0.5, "c0_err": 0.01, "omega_fit": [0.1, 0.2],
           "omega_ref": 0.2, "c_ref": 0.5, "c_ref_err": 0.01, "alpha_ref": -0.00044,
           "alpha_ref_err": 0.00061, "bootstrap": 5}
    md = "\n".join(continuum_section({"sc": {"attenuation": att}}))
    assert "-0.00044" not in md and "-93" not in md and "(-4 ± 6)e-04" not in md
    # α + 2 errors = 0.00078; Q > ω/(2 α_upper c) = 0.1 / (2 × 0.00078 × 0.5) = 128
    assert "| 0.1 | < 7.8e-04 (95 %; consistent with 0) | > 130 (α consistent with 0) | 0.500 ± 0.010 |" in md
    assert "| 0.2 | 0.00200 ± 0.00010 | 250 ± 13 | 0.500 ± 0.010 |" in md
    s = approach_sentence({"status": "beyond", "L_max": 100.0, "L_star": 371.0,
                           "L_star_ci": [4.17, 3.73e7], "L_star_extrapolated": True})
    assert "371" not in s and "The fit does not constrain L* (95 % interval [4.17, 3.73e+07] d, " \
                             "over a decade wide): only L* > 4.2 d." in s


def test_damping_section_states_its_window_and_marks_a_window_in_a_pulse():
    from granwave.report.tables import damping_section

    rows = [{"damping": 0.0, "amplitude": 0.0078, "width": 15.3, "tail_rms": 0.0067,
             "tail_rms_over_amplitude": 0.86, "tail_start": 60.5, "tail_in_pulse": False},
            {"damping": 1.0, "amplitude": 0.0020, "width": 26.7, "tail_rms": 0.00024,
             "tail_rms_over_amplitude": 0.12, "tail_start": 60.5, "tail_in_pulse": True}]
    md = "\n".join(damping_section(rows))
    assert "t ≥ 60.5 d̄/√(E*/ρ)." in md and 'Rows marked "window in pulse"' in md
    assert "| 1 | 0.002 | 26.7 | 0.00024 (window in pulse) | 0.12 |" in md
    assert "(window in pulse) | 0.86 |" not in md


def test_lattice_above_close_packing_is_explained():
    from granwave.report.tables import Groups, close_packing_note

    def lat(phi2):
        return {"pressure": 1e-4, "height": 25.2, "statics": {"phi2": phi2}}

    note = close_packing_note(Groups([lat(0.9133)]))
    assert note and note[0].startswith("Φ2 above the close packing of equal discs, π/(2√3) = "
                                       "0.9069 (up to 0.9133 here), is a matter of definition")
    assert close_packing_note(Groups([lat(0.9069)])) == []
