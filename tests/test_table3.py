"""The paper's Table III: all 18 cases, both readings of the text, and the known differences.

Three kinds of assertion, kept apart because they prove different things (docs/validation.md,
Table III; bowlrec/paper.py):

- **Fit.** The "best-fit" reading changes two inputs so that the printed numbers come out: the
  typical pattern's oil ends at 12.70 m instead of the text's 40 ft (12.192 m; cases 7-16) and
  case 8 is released at y = 0.40 m instead of the lane center. That this reading reproduces
  the paper's hook and pocket angle for cases 7-16 is what the fit was chosen for, so those
  tests (named ``..._best_fit_reading_reproduces_the_paper...``) show the fit still holds, not
  that the physics is right. For the other cases the best-fit reading is the text's.
- **As written against the paper.** The text's reading has nothing fitted: where it agrees with
  the printed numbers it is an independent reproduction; where it does not, the difference is
  asserted as an explicit, named known difference (the printed numbers are rounded, hook to
  1 cm and pocket to 0.1 deg, and some are not reproducible from the text).
- **Not fitted at all.** What the paper states between cases (larger RG and a center-of-mass
  offset slide further, hook more and reach the pins at a larger angle; friction's role; no
  hook without offset or nonscalar inertia; every ball hooks left, as a right-hander's does),
  closed forms of the uniform-ball cases computed here from the paper's inputs (not from
  bowlrec.paper), and convergence of the Table III values under rtol refinement.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bowlrec import simulate
from bowlrec.paper import TABLE_III, paper_scene
from bowlrec.paper_table import ComparisonRow, run_paper_cases, table_cells
from bowlrec.spec import ConstantFriction

R = 0.1085
G = 9.81
V0 = 8.0
W0 = 30.0
L = 18.288
#: the cases the fit changes (the typical pattern); for the others best-fit == as written
FITTED = tuple(range(7, 17))
UNFITTED = tuple(c for c in range(1, 19) if c not in FITTED)


@pytest.fixture(scope="module")
def rows() -> dict[int, ComparisonRow]:
    return {r.paper.case: r for r in run_paper_cases()}


def test_all_cases_reach_the_pins(rows: dict[int, ComparisonRow]) -> None:
    assert sorted(rows) == list(range(1, 19))
    for r in rows.values():
        assert r.as_written.outcome == "pins", r.paper.case
        assert r.best_fit.outcome == "pins", r.paper.case
        assert math.isclose(r.as_written.x_end_m, 18.288, abs_tol=1e-9)


# --- the fit ------------------------------------------------------------------------------------


def test_the_fit_changes_only_the_typical_pattern_cases(rows: dict[int, ComparisonRow]) -> None:
    for case in UNFITTED:
        assert rows[case].best_fit == rows[case].as_written, case
    for case in FITTED:
        assert rows[case].best_fit != rows[case].as_written, case


@pytest.mark.parametrize("case", FITTED)
def test_best_fit_reading_reproduces_the_paper_within_2_5cm_and_0_3deg(
    rows: dict[int, ComparisonRow], case: int
) -> None:
    """A FIT: oil to 12.70 m (and case 8's release at y = 0.40 m) were chosen to reproduce
    these printed numbers; measured: 1.5 cm and 0.23 deg at most (cases 9 and 16)."""
    r = rows[case]
    assert r.best_fit.hook_m == pytest.approx(r.paper.hook_m, abs=0.025)
    assert r.best_fit.pocket_deg == pytest.approx(r.paper.pocket_deg, abs=0.3)


def test_best_fit_reading_reproduces_the_papers_slide_or_to_pins(
    rows: dict[int, ComparisonRow],
) -> None:
    """A FIT for cases 7-16 (as written, case 7 starts rolling 6 cm before the pins); the
    other cases are read as written."""
    for case, r in rows.items():
        if r.paper.slide_m is None:
            assert r.best_fit.slide_m is None, case
        else:
            assert r.best_fit.slide_m is not None, case


# --- as written against the paper (nothing fitted) ----------------------------------------------


@pytest.mark.parametrize("case", [c for c in range(1, 19) if c not in (5, 8)])
def test_as_written_hook_and_pocket(rows: dict[int, ComparisonRow], case: int) -> None:
    """Independent of any fit; measured worst: 4.9 cm (case 7) and 0.46 deg (case 7)."""
    r = rows[case]
    assert r.as_written.hook_m == pytest.approx(r.paper.hook_m, abs=0.05)
    assert r.as_written.pocket_deg == pytest.approx(r.paper.pocket_deg, abs=0.5)


@pytest.mark.parametrize("case", [c for c in UNFITTED if c != 5])
def test_as_written_reproduces_the_unfitted_cases_to_the_printed_precision(
    rows: dict[int, ComparisonRow], case: int
) -> None:
    """The cases no fit touches (constant friction) agree with the printed hook and pocket
    angle to about their printed precision (1 cm, 0.1 deg): measured 0.72 cm (case 17) and
    0.09 deg (case 17) at most. Case 5 is a known difference (below)."""
    r = rows[case]
    assert r.as_written.hook_m == pytest.approx(r.paper.hook_m, abs=0.01)
    assert r.as_written.pocket_deg == pytest.approx(r.paper.pocket_deg, abs=0.1)


def test_case1_slide_is_the_closed_form(rows: dict[int, ComparisonRow]) -> None:
    k2 = 0.067**2
    s0 = 8.0 - R * 30.0
    t_star = s0 / (0.12 * G * (1.0 + R * R / k2))
    x_star = 8.0 * t_star - 0.5 * 0.12 * G * t_star**2
    assert rows[1].as_written.slide_m == pytest.approx(x_star, rel=1e-9)
    assert x_star == pytest.approx(8.173, abs=5e-4)


@pytest.mark.parametrize("case", [1, 2, 3, 4])
def test_known_difference_cases_1_to_4_slide_about_one_percent_farther(
    rows: dict[int, ComparisonRow], case: int
) -> None:
    r = rows[case]
    assert r.paper.slide_m is not None and r.as_written.slide_m is not None
    ratio = r.as_written.slide_m / r.paper.slide_m
    assert 1.005 < ratio < 1.012, ratio


def test_known_difference_case5_hooks_about_3cm_not_7(rows: dict[int, ComparisonRow]) -> None:
    r = rows[5]
    assert r.as_written.hook_m is not None
    assert 0.02 < r.as_written.hook_m < 0.04
    assert abs(r.as_written.hook_m - r.paper.hook_m) > 0.03


def test_known_difference_case8_needs_the_release_13cm_right(
    rows: dict[int, ComparisonRow],
) -> None:
    r = rows[8]
    assert r.as_written.hook_m is not None
    assert abs(r.as_written.hook_m - r.paper.hook_m) > 0.3  # as written: far off
    # the fit (y0 = 0.40 m) reproduces it
    assert r.best_fit.hook_m == pytest.approx(r.paper.hook_m, abs=0.025)


@pytest.mark.parametrize("case", list(range(9, 17)))
def test_known_difference_typical_pattern_slides_short_with_oil_to_40ft(
    rows: dict[int, ComparisonRow], case: int
) -> None:
    r = rows[case]
    assert r.paper.slide_m is not None and r.as_written.slide_m is not None
    assert 0.2 < r.paper.slide_m - r.as_written.slide_m < 0.6
    assert r.best_fit.slide_m is not None  # the fit brings the slides closer
    assert abs(r.best_fit.slide_m - r.paper.slide_m) < abs(r.as_written.slide_m - r.paper.slide_m)


def test_stick_slip_cases_5_and_18_switch_back_to_sliding(rows: dict[int, ComparisonRow]) -> None:
    # realistic deliveries where the rolling ball needs more friction than mu N (docs/physics.md)
    for case in (5, 18):
        assert rows[case].as_written.n_events > 4


def test_table_iii_is_complete() -> None:
    assert [c.case for c in TABLE_III] == list(range(1, 19))


# --- not fitted: what the paper states between cases --------------------------------------------

READINGS = ("as_written", "best_fit")


def _m(rows: dict[int, ComparisonRow], case: int, reading: str) -> tuple[float, float, float]:
    """(slide, hook, pocket) of a case in a reading; slide = the lane's length for "to pins"."""
    s = getattr(rows[case], reading)
    assert s.hook_m is not None and s.pocket_deg is not None
    return (L if s.slide_m is None else s.slide_m, s.hook_m, s.pocket_deg)


@pytest.mark.parametrize("reading", READINGS)
def test_every_ball_hooks_left_as_a_right_handers_does(
    rows: dict[int, ComparisonRow], reading: str
) -> None:
    """Hook and pocket angle are positive toward the left gutter (Table III caption); every
    case that hooks at all hooks left, and reaches the pins heading left."""
    for case in range(4, 19):
        _, hook, pocket = _m(rows, case, reading)
        assert hook > 0.02 and pocket > 0.1, (case, hook, pocket)


def test_no_hook_without_offset_or_nonscalar_inertia_off_axis(
    rows: dict[int, ComparisonRow],
) -> None:
    """Cases 1-3 do not deflect at all (a symmetric ball; an offset perpendicular to omega0;
    a_long perpendicular to omega0), "although the ball slides further" (cases 2 and 3)."""
    for case in (1, 2, 3):
        s = rows[case].as_written
        assert s.hook_m is not None and s.pocket_deg is not None
        assert abs(s.hook_m) < 1e-12 and abs(s.pocket_deg) < 1e-12, case
    slide = {c: rows[c].as_written.slide_m for c in (1, 2, 3)}
    assert slide[1] is not None and slide[2] is not None and slide[3] is not None
    assert slide[1] < slide[2] and slide[1] < slide[3]


@pytest.mark.parametrize("reading", READINGS)
@pytest.mark.parametrize(
    ("smaller", "larger", "why"),
    [
        # P1: a larger RG (cases 9 -> 13, 10 -> 14, ...)
        (9, 13, "RG"),
        (10, 14, "RG"),
        (11, 15, "RG"),
        (12, 16, "RG"),
        # P2: a center-of-mass offset on the left (cases 9 -> 11, 10 -> 12, ...)
        (9, 11, "offset"),
        (10, 12, "offset"),
        (13, 15, "offset"),
        (14, 16, "offset"),
    ],
)
def test_larger_rg_and_an_offset_slide_further_hook_more_and_enter_steeper(
    rows: dict[int, ComparisonRow], reading: str, smaller: int, larger: int, why: str
) -> None:
    """The paper's P1 and P2, demonstrated by the pairs of Table III it names."""
    a, b = _m(rows, smaller, reading), _m(rows, larger, reading)
    for name, x, y in zip(("slide", "hook", "pocket"), a, b, strict=True):
        assert y > x, (why, name, smaller, larger, x, y)


@pytest.mark.parametrize("reading", READINGS)
def test_friction_along_the_lane_makes_the_hook(
    rows: dict[int, ComparisonRow], reading: str
) -> None:
    """Fig. 4 and Sec. IV: leaving the oil, the sideways-rotation ball deflects more (case 7)
    than on an evenly oiled lane (case 6); released further right (case 8) it deflects the
    farthest but starts rolling and enters at a smaller angle than case 7. Case 16 on constant
    low friction (case 17) hardly deflects, never rolls and enters at about 1.5 deg; on
    constant high friction (case 18) it rolls about halfway down the lane and enters about
    2 deg less steeply than case 16: more friction, shorter slide."""
    m = {c: _m(rows, c, reading) for c in (6, 7, 8, 16, 17, 18)}
    assert m[7][1] > m[6][1] and m[7][2] > m[6][2]
    assert m[8][1] > m[7][1] and m[8][2] < m[7][2]
    assert getattr(rows[8], reading).slide_m is not None  # case 8 rolls before the pins
    assert getattr(rows[17], reading).slide_m is None  # mu 0.04: slides to the pins
    assert m[17][0] > m[16][0] > m[18][0]  # mu 0.04 > typical > 0.12: shorter slide
    assert 0.4 < m[18][0] / L < 0.65  # "about halfway down the lane"
    assert m[17][1] < m[16][1] / 1.4 and m[17][2] < m[18][2] < m[16][2]
    assert 1.0 < m[16][2] - m[18][2] < 3.0  # the paper: 4.6 - 2.7 = 1.9 deg


# --- not fitted: closed forms of the uniform ball ----------------------------------------------


def _release(toa_deg: float, omega: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Velocity at release and the slip velocity of the contact point s0 = v0 + w0 x (-R z)."""
    a = math.radians(toa_deg)
    v0 = V0 * np.array([math.cos(a), math.sin(a)])
    wx, wy, _ = omega
    return v0, np.array([v0[0] - R * wy, v0[1] + R * wx])


def _uniform_on_constant_friction(
    toa_deg: float, omega: tuple[float, float, float], rg_m: float, mu: float
) -> tuple[float | None, float, float]:
    """(slide or None, hook, pocket) of a uniform ball on constant friction, by hand: the slip
    of a uniform sphere never turns (ds/dt = -mu g (1 + R^2/k^2) u), so the center moves on a
    parabola with acceleration -mu g u until the slip vanishes and straight on after."""
    v0, s0 = _release(toa_deg, omega)
    u = s0 / np.linalg.norm(s0)
    acc = -mu * G * u
    t_roll = float(np.linalg.norm(s0)) / (mu * G * (1.0 + R * R / rg_m**2))
    x_roll = v0[0] * t_roll + 0.5 * acc[0] * t_roll**2
    if x_roll < L:
        p = v0 * t_roll + 0.5 * acc * t_roll**2
        v = v0 + acc * t_roll
        y, slide = p[1] + v[1] * (L - p[0]) / v[0], float(x_roll)
    else:
        t = (-v0[0] + math.sqrt(v0[0] ** 2 + 2.0 * acc[0] * L)) / acc[0]
        v = v0 + acc * t
        y, slide = v0[1] * t + 0.5 * acc[1] * t**2, None
    hook = y - L * math.tan(math.radians(toa_deg))
    return slide, float(hook), math.degrees(math.atan2(v[1], v[0]))


#: the paper's inputs of its uniform-ball cases (Table III), independently of bowlrec.paper
_FORWARD = (0.0, W0, 0.0)
_SIDEWAYS = (-W0, 0.0, 0.0)
_C15, _S15 = math.cos(math.radians(15.0)), math.sin(math.radians(15.0))
_C35, _S35 = math.cos(math.radians(35.0)), math.sin(math.radians(35.0))
_COMBINATION = (-W0 * _C15 * _S35, W0 * _C15 * _C35, W0 * _S15)


@pytest.mark.parametrize(
    ("case", "toa", "omega", "mu"), [(1, 0.0, _FORWARD, 0.12), (6, -1.8, _SIDEWAYS, 0.04)]
)
def test_uniform_ball_on_constant_friction_is_the_closed_form(
    rows: dict[int, ComparisonRow],
    case: int,
    toa: float,
    omega: tuple[float, float, float],
    mu: float,
) -> None:
    """Cases 1 and 6 (RG 6.7 cm, no offset): slide, hook and pocket angle by hand; measured
    agreement 1e-16 (bowlrec solves these with its own closed form), tolerance 1e-9."""
    slide, hook, pocket = _uniform_on_constant_friction(toa, omega, 0.067, mu)
    s = rows[case].as_written
    assert (s.slide_m is None) == (slide is None)
    if slide is not None:
        assert s.slide_m == pytest.approx(slide, abs=1e-9)
    assert s.hook_m == pytest.approx(hook, abs=1e-9)
    assert s.pocket_deg == pytest.approx(pocket, abs=1e-9)


def test_more_friction_shorter_slide_in_proportion() -> None:
    """Case 1 on other constant friction: the slide is inversely proportional to mu (the
    closed form: t* and x* both scale as 1/mu)."""
    base = paper_scene(1)
    slides = {}
    for mu in (0.06, 0.12, 0.24):
        lane = base.lane.model_copy(update={"friction": ConstantFriction(mu=mu)})
        scene = base.model_copy(
            update={"lane": lane, "options": base.options.model_copy(update={"record": "summary"})}
        )
        s = simulate(scene).summary
        assert s.slide_m is not None
        slides[mu] = s.slide_m
        assert s.slide_m == pytest.approx(
            _uniform_on_constant_friction(0.0, _FORWARD, 0.067, mu)[0], abs=1e-9
        )
    assert slides[0.06] == pytest.approx(2.0 * slides[0.12], rel=1e-12)
    assert slides[0.12] == pytest.approx(2.0 * slides[0.24], rel=1e-12)


@pytest.mark.parametrize(
    ("case", "reading", "toa", "omega", "rg_m"),
    [
        (7, "as_written", -1.8, _SIDEWAYS, 0.067),
        (8, "as_written", -3.0, _SIDEWAYS, 0.067),
        (8, "best_fit", -3.0, _SIDEWAYS, 0.067),
        (9, "as_written", -1.0, _COMBINATION, 0.062),
        (9, "best_fit", -1.0, _COMBINATION, 0.062),
        (13, "as_written", -1.0, _COMBINATION, 0.071),
        (13, "best_fit", -1.0, _COMBINATION, 0.071),
    ],
)
def test_uniform_ball_rolls_to_the_pins_at_the_closed_form_angle(
    rows: dict[int, ComparisonRow],
    case: int,
    reading: str,
    toa: float,
    omega: tuple[float, float, float],
    rg_m: float,
) -> None:
    """On any friction pattern a uniform ball's velocity and slip change in the ratio
    1 : (1 + R^2/k^2) along the fixed slip direction, so it starts rolling at
    v = v0 - s0 k^2 / (k^2 + R^2) however the oil lies, and keeps that velocity to the pins:
    the pocket angle of the uniform typical-pattern cases that roll is independent of the
    pattern and of the fit (measured 4e-15 deg from the hand value, tolerance 1e-9)."""
    s = getattr(rows[case], reading)
    assert s.slide_m is not None and s.slide_m < L  # it rolls before the pins
    v0, s0 = _release(toa, omega)
    v = v0 - s0 * rg_m**2 / (rg_m**2 + R**2)
    assert s.pocket_deg == pytest.approx(math.degrees(math.atan2(v[1], v[0])), abs=1e-9)


# --- not fitted: convergence ---------------------------------------------------------------------


def test_table_iii_values_are_converged(rows: dict[int, ComparisonRow]) -> None:
    """Both readings at rtol 1e-11 (100x tighter than the default): the table as printed in
    docs/validation.md is the same, and the numbers move by at most 4.7e-8 m of slide,
    1.3e-10 m of hook and 4.5e-8 deg of pocket angle (case 18 and 12, measured), far below
    the tolerances of the comparisons above; asserted with the margins of
    tests/test_convergence.py (1e-6 m, 3e-9 m, 1e-6 deg)."""
    tight = run_paper_cases(rtol=1e-11)
    assert table_cells(tight) == table_cells(list(rows.values()))
    for t in tight:
        r = rows[t.paper.case]
        for reading in READINGS:
            a, b = getattr(r, reading), getattr(t, reading)
            assert (a.slide_m is None) == (b.slide_m is None)
            if a.slide_m is not None:
                assert abs(a.slide_m - b.slide_m) < 1e-6, (t.paper.case, reading)
            assert abs(a.hook_m - b.hook_m) < 3e-9, (t.paper.case, reading)
            assert abs(a.pocket_deg - b.pocket_deg) < 1e-6, (t.paper.case, reading)
