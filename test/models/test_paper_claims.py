"""The paper's qualitative claims (MODEL_NOTES section 5) checked on the steady-state model.

One test per claim the steady model can address (the time protocol of the paper's simulations
is not one). Each operating point is solved once per module, in symmetric mode, every curve in
increasing preload so that each solve warm-starts from the previous one. Quantities of one
contact come from :func:`ballscrew_twin.report.paper.contact_side` (the loaded half groove of one
sphere of the given nut). Claims the model does not reproduce are marked ``xfail(strict=True)``
with the measured numbers; their checks are the claim as stated, not weakened to pass.
"""

import math
from collections.abc import Callable

import numpy as np
import pytest

from ballscrew_twin.errors import SolverError
from ballscrew_twin.models.base import FloatArray, TwinOutput
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.params import TwinConfig, load_config
from ballscrew_twin.report.paper import MU_LIT, Side, contact_side, solve_curves

MASTER, SLAVE = 0, 1
PRELOADS = (100.0, 500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0)  # N, Figs. 9-10 at 100 rpm
LINEAR_RANGE = (500.0, 3000.0)  # N, where linearity and the Eq. 52 match are judged
#: (temperature [deg C], speed [rpm]) -> preloads [N], solved in this order. Zero preload (the
#: spheres carry only the nut weights) serves the centrifugal claim of Fig. 11c only.
CURVES: dict[tuple[float, float], tuple[float, ...]] = {
    **{(t, 100.0): (0.0, *PRELOADS) for t in (-20.0, 20.0, 60.0)},
    **{(t, 2000.0): (500.0, 1500.0) for t in (-20.0, 20.0, 60.0)},
    **{(t, 4000.0): (0.0, 100.0, 3000.0) for t in (-20.0, 20.0)},
}
Solved = dict[tuple[float, float, float], TwinOutput]
#: drag(celsius, rpm, preload) -> drag torque [N m]
Drag = Callable[[float, float, float], float]
#: contact(celsius, rpm, preload, side, quantity) -> quantity of one nut's contact (SI)
Contact = Callable[[float, float, float, Side, str], float]


@pytest.fixture(scope="module")
def config() -> TwinConfig:
    return load_config()


@pytest.fixture(scope="module")
def solved(config: TwinConfig) -> Solved:
    """Every operating point of :data:`CURVES`, keyed (temperature C, speed rpm, preload N),
    solved with the report's warm-start sweep; a point that does not converge fails here."""
    result: Solved = {}
    for key, solution in solve_curves(config, CURVES).items():
        if isinstance(solution, SolverError):
            raise AssertionError(f"{key}: {solution}")
        result[key] = solution.output
    return result


@pytest.fixture(scope="module")
def drag(solved: Solved) -> Drag:
    """Drag torque [N m] at (temperature C, speed rpm, preload N)."""
    return lambda celsius, rpm, preload: solved[(celsius, rpm, preload)].drag_torque


def nut_contact(solved: Solved, nut: int) -> Contact:
    """Quantities (:data:`ballscrew_twin.report.paper.CONTACT_QUANTITIES`) of ``nut``'s contacts."""

    def value(celsius: float, rpm: float, preload: float, side: Side, name: str) -> float:
        contacts = solved[(celsius, rpm, preload)].contacts
        assert contacts is not None
        return float(contact_side(contacts, nut, side)[f"{side}_{name}"])

    return value


@pytest.fixture(scope="module")
def master(solved: Solved) -> Contact:
    return nut_contact(solved, MASTER)


@pytest.fixture(scope="module")
def slave(solved: Solved) -> Contact:
    return nut_contact(solved, SLAVE)


def series(
    func: Callable[..., float],
    celsius: float,
    rpm: float,
    *rest: str,
    preloads: tuple[float, ...] = PRELOADS,
) -> FloatArray:
    """``func(celsius, rpm, preload, *rest)`` over ``preloads``."""
    return np.array([func(celsius, rpm, p, *rest) for p in preloads], dtype=np.float64)


def fmt(values: FloatArray, scale: float = 1.0) -> str:
    """Values for an assertion message."""
    return " ".join(f"{v * scale:.4g}" for v in values)


# ------------------------------------------------------------------ drag torque vs preload


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_drag_rises_linearly_with_preload(drag: Drag, celsius: float) -> None:
    """Fig. 9: at 100 rpm the drag torque rises with preload, linearly (R^2 > 0.95, 500-3000 N)."""
    torque = series(drag, celsius, 100.0)
    assert np.all(np.diff(torque) > 0.0), fmt(torque, 1e3)
    inside = [LINEAR_RANGE[0] <= p <= LINEAR_RANGE[1] for p in PRELOADS]
    x, y = np.array(PRELOADS)[inside], torque[inside]
    residual = y - np.polyval(np.polyfit(x, y, 1), x)
    r_squared = 1.0 - np.sum(residual**2) / np.sum((y - y.mean()) ** 2)
    assert r_squared > 0.95


@pytest.mark.parametrize("celsius", [20.0, 60.0])
def test_drag_matches_eq52_at_20_and_60_c(config: TwinConfig, drag: Drag, celsius: float) -> None:
    """Fig. 9: at 100 rpm, 20 and 60 C the drag matches Eq. 52 (mu_lit = 0.002).

    "Match" read off a plot: within 25 % at every preload of 500-3000 N.
    """
    zhou = CatalogModel(config, mu_lit=MU_LIT, formula="zhou")
    preloads = tuple(p for p in PRELOADS if LINEAR_RANGE[0] <= p <= LINEAR_RANGE[1])
    ratio = series(drag, celsius, 100.0, preloads=preloads) / [
        zhou.torque_at_preload(p) for p in preloads
    ]
    assert np.all(np.abs(ratio - 1.0) < 0.25), fmt(ratio)


def test_drag_higher_at_minus_20_c_noticeably_at_low_preload(drag: Drag) -> None:
    """Fig. 9: at -20 C the drag is above the 20 C drag, relatively more at low preload."""
    ratio = series(drag, -20.0, 100.0) / series(drag, 20.0, 100.0)
    assert np.all(ratio > 1.0), fmt(ratio)
    assert ratio[PRELOADS.index(500.0)] > ratio[PRELOADS.index(3000.0)], fmt(ratio)


# ------------------------------------------------------------------ speed


def _relative_rise(drag: Drag, celsius: float, preload: float) -> float:
    return float(drag(celsius, 2000.0, preload) / drag(celsius, 100.0, preload) - 1.0)


@pytest.mark.parametrize(
    "celsius",
    [
        -20.0,
        20.0,
        pytest.param(
            60.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="60 C drag falls with speed at 1500 N: 18.6 N mm at 100 rpm, 15.0 N mm "
                "at 2000 rpm (-20 %), where 20 C rises 18.5 -> 30.5 N mm (+65 %); at 500 N "
                "60 C rises only +14 % (4.86 -> 5.54 N mm): 60 C does not behave like 20 C",
            ),
        ),
    ],
)
def test_drag_rises_with_speed(drag: Drag, celsius: float) -> None:
    """Fig. 11a: higher speed, higher drag (100 -> 2000 rpm), at every temperature."""
    rises = [_relative_rise(drag, celsius, p) for p in (500.0, 1500.0)]
    assert all(rise > 0.0 for rise in rises), rises


def test_speed_effect_much_larger_at_minus_20_c(drag: Drag) -> None:
    """Fig. 11a: the relative rise 100 -> 2000 rpm is much larger (> 2x) at -20 C than at 20 C."""
    for preload in (500.0, 1500.0):
        cold, warm = _relative_rise(drag, -20.0, preload), _relative_rise(drag, 20.0, preload)
        assert cold > 2.0 * warm > 0.0, (preload, cold, warm)


# ------------------------------------------------------------------ lubrication regimes


def test_minus_20_c_full_film(master: Contact) -> None:
    """Fig. 10e/c/d: at -20 C, 100 rpm, Lambda > 3 and the friction is all lubricant shear."""
    for side in ("screw", "nut"):
        tallian = series(master, -20.0, 100.0, side, "tallian_parameter")
        assert np.all(tallian > 3.0), fmt(tallian)
        dry = series(master, -20.0, 100.0, side, "dry_friction_N")
        total = series(master, -20.0, 100.0, side, "friction_force_N")
        assert np.all(dry <= 1e-3 * total), fmt(dry / total)


def test_20_c_mixed_lubrication(master: Contact) -> None:
    """Fig. 10c-e: at 20 C, 100 rpm, Lambda < 3 and film and asperities both carry friction
    (each at least 10 % of it)."""
    for side in ("screw", "nut"):
        tallian = series(master, 20.0, 100.0, side, "tallian_parameter")
        assert np.all(tallian < 3.0), fmt(tallian)
        dry_share = series(master, 20.0, 100.0, side, "dry_friction_N") / series(
            master, 20.0, 100.0, side, "friction_force_N"
        )
        assert np.all((dry_share > 0.1) & (dry_share < 0.9)), fmt(dry_share)


def test_60_c_film_thinner_than_at_20_c(master: Contact) -> None:
    """Fig. 10e: at 60 C the Tallian parameter is below the 20 C one at every preload."""
    for side in ("screw", "nut"):
        hot = series(master, 60.0, 100.0, side, "tallian_parameter")
        warm = series(master, 20.0, 100.0, side, "tallian_parameter")
        assert np.all(hot < warm), (fmt(hot), fmt(warm))


@pytest.mark.xfail(
    strict=True,
    reason="at 60 C, 100 rpm, 100 N the dry part is 5.7 times the lubricant part (screw side "
    "0.0383 vs 0.0067 N; 2.5-2.8 times at 500-3000 N): asperities dominate at low preload",
)
def test_60_c_dry_and_lubricant_parts_comparable(master: Contact) -> None:
    """Fig. 10c-d: at 60 C (almost boundary) the dry and lubricant parts are comparable:
    within a factor of 3 of each other at every preload."""
    for side in ("screw", "nut"):
        ratio = series(master, 60.0, 100.0, side, "dry_friction_N") / series(
            master, 60.0, 100.0, side, "lubricant_friction_N"
        )
        assert np.all((ratio > 1.0 / 3.0) & (ratio < 3.0)), fmt(ratio)


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_tallian_parameter_falls_with_preload(master: Contact, celsius: float) -> None:
    """Fig. 10e: Lambda falls as the preload rises."""
    for side in ("screw", "nut"):
        tallian = series(master, celsius, 100.0, side, "tallian_parameter")
        assert np.all(np.diff(tallian) < 0.0), fmt(tallian)


# ------------------------------------------------------------------ friction coefficient


def test_friction_coefficient_small(master: Contact) -> None:
    """Fig. 11b: F_t/F_n per contact is small (near pure rolling): below 0.1 everywhere."""
    for (celsius, rpm), preloads in CURVES.items():
        for side in ("screw", "nut"):
            mu = series(master, celsius, rpm, side, "friction_coefficient", preloads=preloads)
            assert np.all((mu > 0.0) & (mu < 0.1)), (celsius, rpm, side, fmt(mu))


@pytest.mark.parametrize(
    "celsius",
    [
        pytest.param(
            -20.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at -20 C, 100 rpm, screw-side F_t/F_n rises from 0.01391 (100 N) to "
                "0.01454 (500 N) before falling to 0.01397 (3000 N)",
            ),
        ),
        pytest.param(
            20.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at 20 C, 100 rpm, screw-side F_t/F_n rises with preload: 0.00760 (100 N), "
                "0.00960 (500 N), 0.01015 (1500 N), 0.01030 (3000 N)",
            ),
        ),
        pytest.param(
            60.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at 60 C, 100 rpm, screw-side F_t/F_n rises with preload: 0.00818 (100 N), "
                "0.01017 (500 N), 0.01088 (1500 N), 0.01115 (3000 N)",
            ),
        ),
    ],
)
def test_friction_coefficient_falls_with_preload(master: Contact, celsius: float) -> None:
    """Figs. 10a, 11b: the normal force rises more than the friction force: F_t/F_n falls."""
    for side in ("screw", "nut"):
        mu = series(master, celsius, 100.0, side, "friction_coefficient")
        assert np.all(np.diff(mu) < 0.0), fmt(mu)


def _plateau_preload(mu: FloatArray) -> float:
    """Lowest preload [N] from which on F_t/F_n stays within 5 % of its 3000 N value."""
    inside = np.abs(mu / mu[-1] - 1.0) <= 0.05
    first = len(mu) - int(np.argmin(inside[::-1])) if not inside.all() else 0
    return PRELOADS[first]


@pytest.mark.xfail(
    strict=True,
    reason="plateau (F_t/F_n within 5 % of its 3000 N value, screw side, 100 rpm) reached at "
    "100 N at -20 C, 1000 N at 20 C and 1000 N at 60 C: earliest, not latest, when coldest",
)
def test_friction_plateau_at_higher_preload_when_colder(master: Contact) -> None:
    """Fig. 11b text: as the temperature drops the F_t/F_n plateau is reached at higher preload."""
    plateau = {
        t: _plateau_preload(series(master, t, 100.0, "screw", "friction_coefficient"))
        for t in (-20.0, 20.0, 60.0)
    }
    assert plateau[-20.0] >= plateau[20.0] >= plateau[60.0] and plateau[-20.0] > plateau[60.0], (
        plateau
    )


# ------------------------------------------------------------------ screw side vs nut side


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_screw_side_pressure_higher_area_smaller(master: Contact, celsius: float) -> None:
    """Fig. 10g-h: the screw-side contact is smaller and its maximum pressure higher."""
    pressure = {s: series(master, celsius, 100.0, s, "max_pressure_Pa") for s in ("screw", "nut")}
    area = {s: series(master, celsius, 100.0, s, "contact_area_m2") for s in ("screw", "nut")}
    assert np.all(pressure["screw"] > pressure["nut"])
    assert np.all(area["screw"] < area["nut"])


@pytest.mark.parametrize(
    "celsius",
    [
        -20.0,
        20.0,
        pytest.param(
            60.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at 60 C, 100 rpm, 100 N the nut-side shear stress is higher: 1.49 MPa "
                "vs 1.40 MPa on the screw side (screw side higher from 500 N on)",
            ),
        ),
    ],
)
def test_screw_side_shear_stress_higher(master: Contact, celsius: float) -> None:
    """Fig. 10f: the lubricant shear stress is higher on the screw side."""
    screw = series(master, celsius, 100.0, "screw", "shear_stress_Pa")
    nut = series(master, celsius, 100.0, "nut", "shear_stress_Pa")
    assert np.all(screw > nut), (fmt(screw, 1e-6), fmt(nut, 1e-6))


def _nut_side_higher_at_speed(celsius: float, rpm: float, numbers: str) -> object:
    reason = (
        f"at {celsius:g} C, {rpm:g} rpm the nut-side F_t/F_n is higher: {numbers}; the "
        "spheres' centrifugal force and gyroscopic moment reverse the order, and the dynamic "
        "model (no such terms, dt -> 0) gives the same reversal (docs/model.md, item 3)"
    )
    return pytest.param(celsius, rpm, marks=pytest.mark.xfail(strict=True, reason=reason))


@pytest.mark.parametrize(
    ("celsius", "rpm"),
    [
        (-20.0, 100.0),
        (20.0, 100.0),
        (60.0, 100.0),
        (-20.0, 2000.0),
        _nut_side_higher_at_speed(
            20.0, 2000.0, "0.009298/0.009483 vs 0.009378/0.009512 (500/1500 N)"
        ),
        _nut_side_higher_at_speed(
            60.0, 2000.0, "0.005876/0.006444 vs 0.005975/0.006477 (500/1500 N)"
        ),
        (-20.0, 4000.0),
        _nut_side_higher_at_speed(
            20.0, 4000.0, "0.008853/0.009491 vs 0.009140/0.009555 at 100/3000 N (not at 0 N)"
        ),
    ],
)
def test_screw_side_friction_coefficient_higher(
    master: Contact, celsius: float, rpm: float
) -> None:
    """Figs. 10a, 11b: F_t/F_n is (slightly) higher on the screw side, at every speed."""
    preloads = CURVES[(celsius, rpm)]
    screw = series(master, celsius, rpm, "screw", "friction_coefficient", preloads=preloads)
    nut = series(master, celsius, rpm, "nut", "friction_coefficient", preloads=preloads)
    assert np.all(screw > nut), (fmt(screw), fmt(nut))


# ------------------------------------------------------------------ contact angles


@pytest.mark.parametrize(
    "celsius",
    [
        pytest.param(
            -20.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at -20 C, 100 rpm, the nut-side angle is 44.53 deg at 100 N and 45.09 deg "
                "at 500 N: it first approaches the nominal 45 deg, then moves away",
            ),
        ),
        20.0,
        60.0,
    ],
)
def test_contact_angles_move_away_from_nominal(
    config: TwinConfig, master: Contact, celsius: float
) -> None:
    """Fig. 10b: the higher the preload, the further the angles are from the nominal 45 deg."""
    nominal = config.screw.nominal_contact_angle
    for side in ("screw", "nut"):
        angle = series(master, celsius, 100.0, side, "contact_angle_rad")
        assert np.all(np.diff(np.abs(angle - nominal)) > 0.0), fmt(np.degrees(angle))


def _split(master: Contact, celsius: float, rpm: float, preload: float) -> float:
    """|screw-side - nut-side| contact angle [rad]."""
    return abs(
        master(celsius, rpm, preload, "screw", "contact_angle_rad")
        - master(celsius, rpm, preload, "nut", "contact_angle_rad")
    )


@pytest.mark.parametrize(
    ("celsius", "low_preload"),
    [
        (-20.0, 0.0),
        pytest.param(
            20.0,
            0.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at 20 C, 0 N the start-up state at 4000 rpm has the spheres travelling "
                "with their nut (w_B / Omega = -1.000, zero entrainment on the nut grooves, "
                "reached continuously from rolling between 240 and 450 rpm since D16): split "
                "0.05 deg more than at 100 rpm (3000 N: -0.08 deg)",
            ),
        ),
        pytest.param(
            -20.0,
            100.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at -20 C, 100 N the screw/nut angle split shrinks with speed: 1.51 deg at "
                "100 rpm, 0.80 deg at 4000 rpm (3000 N: 1.60 -> 1.56 deg); the centrifugal "
                "split exists at 0 N only (0.31 -> 11.5 deg)",
            ),
        ),
        pytest.param(
            20.0,
            100.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at 20 C the screw/nut angle split barely changes with speed: 100 N "
                "0.86 -> 0.89 deg, 3000 N 1.18 -> 1.10 deg (100 -> 4000 rpm); the centrifugal "
                "split exists at 0 N only (0.31 -> 13.8 deg)",
            ),
        ),
    ],
)
def test_centrifugal_angle_split_at_low_preload_only(
    master: Contact, celsius: float, low_preload: float
) -> None:
    """Fig. 11c: at low preload the speed (centrifugal force) splits the screw-side and nut-side
    angles; at high preload it does not. The split added by 100 -> 4000 rpm at the low preload
    is positive and larger than the change the speed makes at 3000 N."""
    low = _split(master, celsius, 4000.0, low_preload) - _split(master, celsius, 100.0, low_preload)
    high = _split(master, celsius, 4000.0, 3000.0) - _split(master, celsius, 100.0, 3000.0)
    assert low > abs(high) and low > 0.0, (math.degrees(low), math.degrees(high))


# ------------------------------------------------------------------ master vs slave nut


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_master_ball_forces_slightly_lower_than_slave(
    master: Contact, slave: Contact, celsius: float
) -> None:
    """Fig. 10a text: on the vertical screw the nut weights load the lower (slave) nut, so its
    spheres carry slightly (less than 10 %) more than the master nut's."""
    for side in ("screw", "nut"):
        upper = series(master, celsius, 100.0, side, "normal_force_N")
        lower = series(slave, celsius, 100.0, side, "normal_force_N")
        excess = lower / upper - 1.0
        assert np.all((excess > 0.0) & (excess < 0.1)), fmt(excess)


# ------------------------------------------------------------------ claims added for issue 15
# Measured with ``ballscrew-twin report gaps`` too (docs/model.md, "Against the paper: open
# gaps, measured").


@pytest.mark.xfail(
    strict=True,
    reason="drag / Eq. 52 at 500..3000 N: 0.838..1.104 at 20 C, 0.760..1.152 at 60 C; the drag "
    "grows as F_pr^1.15 (20 C) and F_pr^1.23 (60 C) because MER, MC and MP grow as "
    "F^1.34-1.69 (docs/model.md, Against the paper)",
)
@pytest.mark.parametrize("celsius", [20.0, 60.0])
def test_drag_within_10_percent_of_eq52(config: TwinConfig, drag: Drag, celsius: float) -> None:
    """Issue 15 goal for the Fig. 9 statement: within 10 % of Eq. 52 at 500-3000 N."""
    zhou = CatalogModel(config, mu_lit=MU_LIT, formula="zhou")
    preloads = tuple(p for p in PRELOADS if LINEAR_RANGE[0] <= p <= LINEAR_RANGE[1])
    ratio = series(drag, celsius, 100.0, preloads=preloads) / [
        zhou.torque_at_preload(p) for p in preloads
    ]
    assert np.all(np.abs(ratio - 1.0) <= 0.10), fmt(ratio)


def _slope_bends(celsius: float, low: float, high: float) -> object:
    reason = (
        f"at {celsius:g} C the slope rises from {low:g} N mm/kN (500-1500 N) to {high:g} N mm/kN "
        "(1500-3000 N): the rolling moments MER, MC, MP grow faster than the preload"
    )
    return pytest.param(celsius, marks=pytest.mark.xfail(strict=True, reason=reason))


@pytest.mark.parametrize(
    "celsius", [-20.0, _slope_bends(20.0, 13.17, 15.85), _slope_bends(60.0, 13.77, 17.02)]
)
def test_drag_slope_constant_over_preload(drag: Drag, celsius: float) -> None:
    """Fig. 9, Conclusions: the drag is a linear function of the preload, read strictly: the
    slope over 1500-3000 N is within 10 % of the slope over 500-1500 N."""
    low = (drag(celsius, 100.0, 1500.0) - drag(celsius, 100.0, 500.0)) / 1000.0
    high = (drag(celsius, 100.0, 3000.0) - drag(celsius, 100.0, 1500.0)) / 1500.0
    assert abs(high / low - 1.0) <= 0.10, (low * 1e6, high * 1e6)


@pytest.mark.parametrize("celsius", [-20.0, 20.0])
def test_drag_slope_rises_with_speed(drag: Drag, celsius: float) -> None:
    """Conclusions: the variation rate of the drag with preload depends on the speed: the slope
    over 100-3000 N is steeper at 4000 rpm than at 100 rpm."""
    slope = {
        rpm: (drag(celsius, rpm, 3000.0) - drag(celsius, rpm, 100.0)) / 2900.0
        for rpm in (100.0, 4000.0)
    }
    assert slope[4000.0] > slope[100.0], slope


@pytest.mark.xfail(
    strict=True,
    reason="at 3000 N, 100 rpm the angles split by 1.60 (-20 C), 1.18 (20 C) and 1.28 deg "
    "(60 C), 2 atan(F_t/F_n) to 0.3 %: the contact friction is transverse to rolling (>= 99.7 % "
    "of the tangential force) and tilts each contact force by atan(F_t/F_n)",
)
@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_angles_do_not_split_at_high_preload(master: Contact, celsius: float) -> None:
    """Fig. 11c: at high preload the screw-side and nut-side contact angles do not differ. Read
    off a plot spanning tens of degrees: less than 0.5 deg apart at 3000 N, at every speed."""
    for (temp, rpm), preloads in CURVES.items():
        if temp == celsius and 3000.0 in preloads:
            assert math.degrees(_split(master, celsius, rpm, 3000.0)) < 0.5, rpm


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_screw_and_nut_normal_forces_almost_equal(master: Contact, celsius: float) -> None:
    """Fig. 10a text: the screw-side and nut-side normal forces of a sphere are almost equal
    (they differ by the sphere's weight): within 1 % at 100-3000 N."""
    screw = series(master, celsius, 100.0, "screw", "normal_force_N")
    nut = series(master, celsius, 100.0, "nut", "normal_force_N")
    assert np.all(np.abs(screw / nut - 1.0) < 0.01), fmt(screw / nut - 1.0)


@pytest.mark.parametrize(
    ("colder", "warmer"),
    [
        (-20.0, 20.0),
        pytest.param(
            20.0,
            60.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="at 100 rpm the screw-side F_t/F_n is higher at 60 C (0.00818 at 100 N, "
                "0.01115 at 3000 N) than at 20 C (0.00760, 0.01030): at 60 C the asperities "
                "carry part of the load with mu_dry = 0.0175 above the film's traction",
            ),
        ),
    ],
)
def test_friction_coefficient_higher_when_colder(
    master: Contact, colder: float, warmer: float
) -> None:
    """Fig. 10a/11b, Conclusions: higher friction coefficients at lower temperature: screw-side
    F_t/F_n at -20 C above 20 C above 60 C at every preload (100 rpm)."""
    cold = series(master, colder, 100.0, "screw", "friction_coefficient")
    warm = series(master, warmer, 100.0, "screw", "friction_coefficient")
    assert np.all(cold > warm), (fmt(cold), fmt(warm))


def test_film_thicker_when_colder(master: Contact) -> None:
    """Fig. 10e, Conclusions: the lower the temperature, the thicker the film: Lambda at -20 C
    above 20 C at every preload (20 C above 60 C: test_60_c_film_thinner_than_at_20_c)."""
    for side in ("screw", "nut"):
        cold = series(master, -20.0, 100.0, side, "tallian_parameter")
        warm = series(master, 20.0, 100.0, side, "tallian_parameter")
        assert np.all(cold > warm), (fmt(cold), fmt(warm))


def test_shear_stress_higher_when_colder(master: Contact) -> None:
    """Fig. 10f: the lubricant shear stress rises as the temperature falls (-20 > 20 > 60 C)."""
    for side in ("screw", "nut"):
        tau = {t: series(master, t, 100.0, side, "shear_stress_Pa") for t in (-20.0, 20.0, 60.0)}
        assert np.all(tau[-20.0] > tau[20.0]), (side, fmt(tau[-20.0]), fmt(tau[20.0]))
        assert np.all(tau[20.0] > tau[60.0]), (side, fmt(tau[20.0]), fmt(tau[60.0]))


@pytest.mark.xfail(
    strict=True,
    reason="at 20 C, 100 rpm the dry part is 24 % of the screw-side friction at 100 N and "
    "28 % at 3000 N (nut side 19 %, 24 %; 0 at 4000 rpm): the film carries most of it at 100 rpm",
)
def test_friction_moves_from_asperities_to_film_with_speed(master: Contact) -> None:
    """Fig. 11b text: at low speed the film is not built up and the friction comes mainly from
    the asperities (20 C, 100 rpm: dry part above half), at high speed almost entirely from the
    film (dry part below 10 % at 4000 rpm), at 100 and 3000 N."""
    for side in ("screw", "nut"):
        for preload in (100.0, 3000.0):
            shares = [
                master(20.0, rpm, preload, side, "dry_friction_N")
                / master(20.0, rpm, preload, side, "friction_force_N")
                for rpm in (100.0, 4000.0)
            ]
            assert shares[0] > 0.5 and shares[1] < 0.1, (side, preload, shares)


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_master_and_slave_friction_coefficients_alike(
    master: Contact, slave: Contact, celsius: float
) -> None:
    """Fig. 11b text: no significant difference between master and slave nut without external
    load: F_t/F_n within 5 % of each other at 100-3000 N."""
    for side in ("screw", "nut"):
        upper = series(master, celsius, 100.0, side, "friction_coefficient")
        lower = series(slave, celsius, 100.0, side, "friction_coefficient")
        assert np.all(np.abs(lower / upper - 1.0) < 0.05), fmt(lower / upper - 1.0)


def _slip(solved: Solved, celsius: float, rpm: float, preload: float, side: Side) -> float:
    """Centre slip speed [m/s] of the master nut's loaded contact on ``side``."""
    contacts = solved[(celsius, rpm, preload)].contacts
    assert contacts is not None
    sphere = contacts.sphere[contacts.nut == MASTER][0]
    on_side = (contacts.half_groove >= 2) if side == "nut" else (contacts.half_groove < 2)
    rows = np.flatnonzero((contacts.sphere == sphere) & on_side)
    return float(contacts.slip_speed[rows[np.argmax(contacts.normal_force[rows])]])


@pytest.mark.xfail(
    strict=True,
    reason="at 100 rpm, 100 N the screw-side slip is smaller: 0.75 vs 0.96 mm/s (-20 C), "
    "0.52 vs 1.13 (20 C), 0.40 vs 1.25 (60 C); the slip is transverse to rolling",
)
@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_screw_side_slips_more(solved: Solved, celsius: float) -> None:
    """Section 3: the slip in the sphere/screw contact is usually greater than in the sphere/nut
    contact (the screw drives): here at every preload at 100 rpm."""
    for preload in PRELOADS:
        screw = _slip(solved, celsius, 100.0, preload, "screw")
        nut = _slip(solved, celsius, 100.0, preload, "nut")
        assert screw > nut, (preload, screw, nut)


# ------------------------------------------------------------------ claims added in round 2
# The paper's section 3 and conclusions read again sentence by sentence: these statements had
# no test yet. Measured values: `report gaps --study eq52` prints the breakdown by mechanism.

SLIDING_SHARE_REASON = (
    "the sliding friction of Eq. 36 makes 26 % (-20 C), 30 % (20 C) and 31 % (60 C) of the "
    "drag's rise from 500 to 3000 N at 100 rpm, MER, MC and MP 61 %, 68 % and 69 % (20 C, "
    "3000 N: lubricant 9.74, dry 3.39, MER 11.40, MC 4.45, MP 11.43, FR/FP 1.89 N mm)"
)
SIXTY_LIKE_TWENTY_REASON = (
    "at 2000 rpm the 60 C drag is 62 % below the 20 C drag at 500 N (5.54 vs 14.76 N mm) and "
    "51 % below at 1500 N (14.96 vs 30.51 N mm): at 60 C the drag falls with speed from "
    "100 rpm (mu_dry above the film's traction, docs/model.md item 3)"
)


@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_contact_forces_rise_with_preload(master: Contact, celsius: float) -> None:
    """Fig. 10a: increasing the preload raises the normal contact forces and the friction
    forces, on the screw and the nut side, whatever the temperature (100 rpm)."""
    for side in ("screw", "nut"):
        for name in ("normal_force_N", "friction_force_N"):
            values = series(master, celsius, 100.0, side, name)
            assert np.all(np.diff(values) > 0.0), (side, name, fmt(values))


def _sliding_share_of_rise(solved: Solved, celsius: float) -> float:
    """Share of the drag's rise from 500 to 3000 N (100 rpm) that the sliding friction of
    Eq. 36 (lubricant shear and dry contact) makes [-]."""

    def sliding(preload: float) -> float:
        parts = solved[(celsius, 100.0, preload)].breakdown
        return parts.lubricant_shear + parts.dry_contact

    def total(preload: float) -> float:
        return solved[(celsius, 100.0, preload)].drag_torque

    return (sliding(3000.0) - sliding(500.0)) / (total(3000.0) - total(500.0))


@pytest.mark.xfail(strict=True, reason=SLIDING_SHARE_REASON)
@pytest.mark.parametrize("celsius", [-20.0, 20.0, 60.0])
def test_friction_forces_make_most_of_the_drag_rise(solved: Solved, celsius: float) -> None:
    """Fig. 10a text: the friction forces "are the major responsible for the friction torque
    increase": the sliding friction (Eq. 36) makes more than half of the drag's rise from 500
    to 3000 N at 100 rpm."""
    assert _sliding_share_of_rise(solved, celsius) > 0.5


@pytest.mark.xfail(strict=True, reason=SIXTY_LIKE_TWENTY_REASON)
def test_60_c_drag_like_20_c_at_speed(drag: Drag) -> None:
    """Fig. 11a text: "the 60 C curve is similar to the 20 C one" (and is left out of the
    figure): at 2000 rpm, 500 and 1500 N, the 60 C drag within 25 % of the 20 C drag (the
    tolerance of reading a plot, as for Eq. 52)."""
    for preload in (500.0, 1500.0):
        ratio = drag(60.0, 2000.0, preload) / drag(20.0, 2000.0, preload)
        assert abs(ratio - 1.0) < 0.25, (preload, ratio)


@pytest.mark.parametrize(
    ("colder", "warmer", "rpm", "preloads"),
    [(-20.0, 20.0, 4000.0, (100.0, 3000.0)), (20.0, 60.0, 2000.0, (500.0, 1500.0))],
)
def test_film_friction_lower_when_warmer_at_speed(
    master: Contact, colder: float, warmer: float, rpm: float, preloads: tuple[float, float]
) -> None:
    """Fig. 11b text, Conclusions: at high speed the friction is the film's, which creates less
    friction at higher temperature: F_t/F_n lower at 20 C than at -20 C (4000 rpm) and at 60 C
    than at 20 C (2000 rpm), both sides."""
    for side in ("screw", "nut"):
        for preload in preloads:
            cold = master(colder, rpm, preload, side, "friction_coefficient")
            warm = master(warmer, rpm, preload, side, "friction_coefficient")
            assert warm < cold, (side, preload, cold, warm)
