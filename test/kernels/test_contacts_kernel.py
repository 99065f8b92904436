"""The compiled contact kernel equals the numpy reference ``evaluate_contacts``.

Oracle: ``ballscrew_twin.models.contact_forces.evaluate_contacts`` itself. Every field of the
``ContactEvaluation`` must agree to 1e-9 relative, or to 1e-12 of the field's own scale where the
value is near zero (forces at equilibrium are sums of ~100 N terms cancelling to ~1e-10 N; their
scale is the contact force, that of the moments the contact force times the ball radius).

States: steady states of the paper's screw at its operating points (symmetric and full mode;
solved with the compiled kernel in the solver for speed, the states only need to be realistic),
seeded random perturbations of them that lose and gain contacts, contacts clipped by the
containment window, smooth surfaces (infinite Tallian parameter) and all three viscosity laws.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Iterator
from typing import Literal

import numpy as np
import pytest
from numpy.typing import NDArray

from ballscrew_twin.kernels import contact_law, contact_layout
from ballscrew_twin.kernels import scalar_laws as kernel
from ballscrew_twin.kernels.contacts import (
    contacts_kernel,
    evaluate_contacts_compiled,
    scene_arrays,
)
from ballscrew_twin.models import steady
from ballscrew_twin.models.base import DISSIPATION_KEYS, MECHANISMS, OperatingPoint
from ballscrew_twin.models.contact_forces import (
    ContactEvaluation,
    ContactScene,
    evaluate_contacts,
    make_scene,
)
from ballscrew_twin.models.steady import SteadySolution, SteadyStateModel
from ballscrew_twin.params import TwinConfig, ViscosityLaw, load_config
from ballscrew_twin.physics import film, hertz, lubricant, rolling, traction

FloatArray = NDArray[np.float64]
RPM = 2.0 * math.pi / 60.0
RTOL = 1e-9
ATOL_OF_SCALE = 1e-12

# (rpm, Celsius, preload N): the paper's points, zero speed and zero preload.
POINTS = {
    "20C-100rpm-1500N": (100.0, 20.0, 1500.0),
    "-20C-1000rpm-500N": (1000.0, -20.0, 500.0),
    "60C-100rpm-3000N": (100.0, 60.0, 3000.0),
    "20C-0rpm-1500N": (0.0, 20.0, 1500.0),
    "20C-100rpm-0N": (100.0, 20.0, 0.0),
}
MODES: tuple[Literal["symmetric"], Literal["full"]] = ("symmetric", "full")


@dataclasses.dataclass(frozen=True)
class Case:
    """Arguments of one contact evaluation."""

    scene: ContactScene
    ball_nb: FloatArray
    kinematics: FloatArray
    nut_offset: FloatArray
    gravity: FloatArray

    def args(self) -> tuple[ContactScene, FloatArray, FloatArray, FloatArray, FloatArray]:
        return (self.scene, self.ball_nb, self.kinematics, self.nut_offset, self.gravity)


def operating_point(rpm: float, celsius: float, preload: float) -> OperatingPoint:
    return OperatingPoint(screw_speed=rpm * RPM, temperature=celsius + 273.15, preload=preload)


def solve_with_kernel(
    config: TwinConfig, mode: steady.Mode, point: OperatingPoint
) -> SteadySolution:
    """Steady state with the compiled kernel swapped into the solver (same laws, faster)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(steady, "evaluate_contacts", evaluate_contacts_compiled)
        return SteadyStateModel(config, mode=mode).solve(point)


def case_of(solution: SteadySolution, scene: ContactScene) -> Case:
    state, balls = solution.state, solution.balls
    return Case(
        scene,
        state.ball_nb.copy(),
        state.kinematics.copy(),
        state.nut_offset[balls.nut].copy(),
        balls.gravity.copy(),
    )


@pytest.fixture(scope="module")
def config() -> TwinConfig:
    return load_config()


@pytest.fixture(scope="module")
def solved(config: TwinConfig) -> dict[tuple[str, str], Case]:
    """Steady states at every point in both modes."""
    cases: dict[tuple[str, str], Case] = {}
    for mode in MODES:
        for name, (rpm, celsius, preload) in POINTS.items():
            point = operating_point(rpm, celsius, preload)
            solution = solve_with_kernel(config, mode, point)
            scene = make_scene(config, point.temperature, point.screw_speed)
            cases[(name, mode)] = case_of(solution, scene)
    return cases


# ----------------------------------------------------------------------------- comparison
def _fields(ev: ContactEvaluation) -> Iterator[tuple[str, NDArray[np.generic]]]:
    for field in dataclasses.fields(ev):
        value = getattr(ev, field.name)
        if field.name == "hertz":
            for key, array in value._asdict().items():
                yield f"hertz.{key}", array
        elif field.name == "dissipation":
            assert list(value) == list(DISSIPATION_KEYS)
            for key, array in value.items():
                yield f"dissipation.{key}", array
        else:
            yield field.name, value


def compare(ref: ContactEvaluation, got: ContactEvaluation, scene: ContactScene) -> float:
    """Assert equality within tolerance; return the largest relative difference found among
    values that are not near zero (|ref| > 1e-6 of the field's scale)."""
    ref_fields = dict(_fields(ref))
    got_fields = dict(_fields(got))
    assert ref_fields.keys() == got_fields.keys()
    contact_scale = float(np.max(np.abs(ref.groove_force), initial=0.0)) + scene.ball_mass * 9.81
    # Powers are judged against the largest power of any mechanism (the damping power of a
    # steady state is round-off, ~1e-35 W, and has no scale of its own).
    power_scale = max(float(np.max(np.abs(v), initial=0.0)) for v in ref.dissipation.values())
    geom = scene.geometry
    worst = 0.0
    for name, ref_value in ref_fields.items():
        value = got_fields[name]
        assert value.shape == ref_value.shape, name
        if ref_value.dtype == np.bool_:
            assert value.dtype == np.bool_, name
            np.testing.assert_array_equal(value, ref_value, err_msg=name)
            continue
        a = np.asarray(value, dtype=np.float64)
        b = np.asarray(ref_value, dtype=np.float64)
        assert not np.isnan(b).any(), f"reference {name} has NaN"
        np.testing.assert_array_equal(np.isinf(a), np.isinf(b), err_msg=name)
        finite = np.isfinite(b)
        np.testing.assert_array_equal(a[~finite], b[~finite], err_msg=name)
        a, b = a[finite], b[finite]
        if name == "force":
            scale = contact_scale
        elif name == "moment":
            scale = contact_scale * geom.ball_radius  # type: ignore[attr-defined]
        elif name.startswith("dissipation."):
            scale = power_scale
        else:
            scale = float(np.max(np.abs(b), initial=0.0))
        diff = np.abs(a - b)
        allowed = RTOL * np.abs(b) + ATOL_OF_SCALE * scale
        bad = diff > allowed
        assert not bad.any(), (
            f"{name}: {int(bad.sum())} values differ, worst |diff| {diff.max():.3g} "
            f"(ref {b[np.argmax(diff - allowed)]:.6g}, scale {scale:.3g})"
        )
        significant = np.abs(b) > 1e-6 * scale
        if significant.any():
            worst = max(worst, float(np.max(diff[significant] / np.abs(b[significant]))))
    return worst


def check(case: Case) -> float:
    ref = evaluate_contacts(*case.args())
    got = evaluate_contacts_compiled(*case.args())
    return compare(ref, got, case.scene)


def perturbed(case: Case, rng: np.random.Generator, size: float) -> Case:
    """Random perturbation: offsets by ``size`` [m] (contacts lost and gained), rates by
    ~10 % of their scale, gravity direction and magnitude."""
    count = len(case.ball_nb)
    rate_scale = max(abs(case.scene.screw_speed), 1.0)
    return Case(
        case.scene,
        case.ball_nb + rng.normal(0.0, size, (count, 2)),
        case.kinematics * (1.0 + rng.normal(0.0, 0.1, (count, 4)))
        + rng.normal(0.0, 0.02 * rate_scale, (count, 4)),
        case.nut_offset + rng.normal(0.0, size, count),
        case.gravity + rng.normal(0.0, 2.0, (count, 3)),
    )


# ----------------------------------------------------------------------------- tests
def test_law_constants_are_those_of_the_reference() -> None:
    """The kernel's copies of the law constants (frozen into its cached code) are current."""
    assert kernel.FILM_MIN_LOAD == film.FILM_MIN_LOAD
    assert kernel.ENTRAINMENT_SMOOTHING_SPEED == film.ENTRAINMENT_SMOOTHING_SPEED
    assert kernel.ANTOINE_NUMERATOR == hertz._ANTOINE_NUMERATOR
    assert kernel.ANTOINE_DENOMINATOR == hertz._ANTOINE_DENOMINATOR
    assert kernel.K_POLY == hertz._K_POLY
    assert kernel.K_LOG_POLY == hertz._K_LOG_POLY
    assert kernel.E_POLY == hertz._E_POLY
    assert kernel.E_LOG_POLY == hertz._E_LOG_POLY
    for name in (
        "ROELANDS_PRESSURE_SCALE",
        "ROELANDS_LN_ETA_INF",
        "ROELANDS_T_INF",
        "WALTHER_SHIFT",
        "DOWSON_HIGGINSON_A",
        "DOWSON_HIGGINSON_B",
    ):
        assert getattr(kernel, name) == getattr(lubricant, name), name
    for name in ("LOAD_SHARE_A", "LOAD_SHARE_EXP_NUM", "LOAD_SHARE_B", "LOAD_SHARE_EXP_DEN"):
        assert getattr(kernel, name) == getattr(traction, name), name
    assert math.isclose(kernel.LOAD_SHARE_PEAK, traction.LOAD_SHARE_PEAK, rel_tol=1e-15)
    assert math.isclose(kernel.LOAD_SHARE_PEAK_VALUE, traction.LOAD_SHARE_PEAK_VALUE, rel_tol=1e-15)
    for name in ("MER_CONSTANT", "MER_RADIUS_EXPONENT", "MER_LOAD_EXPONENT", "MC_CONSTANT"):
        assert getattr(kernel, name) == getattr(rolling, name), name
    from ballscrew_twin.models import contact_forces

    assert contact_law.SPIN_SLIDING_FACTOR == contact_forces.SPIN_SLIDING_FACTOR
    rows = contact_layout.CONTACT_FIELDS[-len(DISSIPATION_KEYS) :]  # "spin" is a field name too
    assert rows == (*MECHANISMS[:-1], "spin_dissipation", "normal_damping")


def test_smoothed_film_laws_equal_the_reference_through_zero_speed(config: TwinConfig) -> None:
    """D16 in the kernel: film, thermal factor (with its slide-to-roll ratio on |u|_e) and FR
    at entrainment speeds through 0 (and at +-u_e) equal the reference's laws to 1e-12."""
    scene = make_scene(config, 253.15, 100.0)
    lub = config.lubricant
    u_e = film.ENTRAINMENT_SMOOTHING_SPEED
    r_x, r_y, f_n, p_max, slide = 1.3e-3, 2.4e-2, 12.0, 1.1e9, 2e-3
    speeds = [-0.3, -u_e, -1e-6, 0.0, 1e-7, u_e, 3e-4, 0.02, 1.5]
    for u in speeds:
        h_ref = film.film_thickness_central_isothermal(
            f_n,
            u,
            scene.viscosity_atm,
            r_x,
            r_y,
            scene.e_reduced,
            lub.pressure_viscosity_coefficient,
        )
        h_kernel = kernel.film_central_isothermal(
            f_n,
            u,
            scene.viscosity_atm,
            r_x,
            r_y,
            scene.e_reduced,
            lub.pressure_viscosity_coefficient,
        )
        assert h_kernel == pytest.approx(float(h_ref), rel=1e-12), u
        srr = abs(slide) / float(film.smoothed_speed(u))
        l_th = film.thermal_loading_parameter(
            scene.viscosity_atm, lub.viscosity_temperature_coefficient, u, lub.thermal_conductivity
        )
        c_ref = film.thermal_reduction_factor(p_max, scene.e_reduced, l_th, srr)
        c_kernel = kernel.thermal_reduction_factor(
            p_max,
            scene.e_reduced,
            scene.viscosity_atm,
            lub.viscosity_temperature_coefficient,
            u,
            lub.thermal_conductivity,
            srr,
        )
        assert c_kernel == pytest.approx(float(c_ref), rel=1e-12), u
        fr_ref = rolling.rolling_resistance_force(
            f_n, u, scene.viscosity_atm, r_x, r_y, scene.e_reduced
        ) * rolling.smoothed_sign(u)
        fr_kernel = kernel.rolling_resistance_force(
            f_n, u, scene.viscosity_atm, r_x, r_y, scene.e_reduced
        ) * (u / kernel.smoothed_speed(u))
        assert fr_kernel == pytest.approx(float(fr_ref), rel=1e-12, abs=1e-300), u


def test_scene_arrays_fill_the_kernel_signature(config: TwinConfig) -> None:
    params = scene_arrays(make_scene(config, 300.0, 10.0))
    names = list(inspect.signature(contacts_kernel.py_func).parameters)
    arrays = names.index("ball_radius")  # state arrays and the dynamic flag come first
    assert names[:arrays][-1] == "dynamic"
    assert len(params) == len(names) - arrays
    assert isinstance(params[names.index("law") - arrays], int)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("point", list(POINTS))
def test_operating_points(solved: dict[tuple[str, str], Case], point: str, mode: str) -> None:
    case = solved[(point, mode)]
    assert case.ball_nb.shape[0] == (2 if mode == "symmetric" else 50)
    check(case)


def test_random_perturbations_lose_and_gain_contacts(
    solved: dict[tuple[str, str], Case],
) -> None:
    rng = np.random.default_rng(20210413)
    lost = gained = 0
    for (_point, mode), base in solved.items():
        base_active = evaluate_contacts(*base.args()).active
        samples = 12 if mode == "symmetric" else 3
        for sample in range(samples):
            size = (0.3e-6, 2e-6, 8e-6)[sample % 3]
            case = perturbed(base, rng, size)
            active = evaluate_contacts(*case.args()).active
            lost += int(np.sum(base_active & ~active))
            gained += int(np.sum(~base_active & active))
            check(case)
    assert lost > 0 and gained > 0


@pytest.mark.parametrize("law", ["roelands", "exponential", "walther"])
def test_viscosity_laws(
    config: TwinConfig, solved: dict[tuple[str, str], Case], law: ViscosityLaw
) -> None:
    lub = dataclasses.replace(config.lubricant, viscosity_law=law)
    cfg = dataclasses.replace(config, lubricant=lub)
    rng = np.random.default_rng(7)
    for point in POINTS:
        base = solved[(point, "symmetric")]
        scene = make_scene(cfg, base.scene.temperature, base.scene.screw_speed)
        assert scene.viscosity_atm == pytest.approx(
            float(lubricant.viscosity_atmospheric(lub, base.scene.temperature))
        )
        case = dataclasses.replace(base, scene=scene)
        check(case)
        check(perturbed(case, rng, 0.5e-6))


def test_containment_window_and_smooth_surfaces(
    config: TwinConfig, solved: dict[tuple[str, str], Case]
) -> None:
    """Contacts that interpenetrate outside DCA_i..DCA_o are inactive; zero roughness gives
    an infinite Tallian parameter (full film)."""
    screw = dataclasses.replace(
        config.screw,
        inner_containment_angle=0.80,
        outer_containment_angle=0.84,
        ball_roughness=0.0,
        groove_roughness=0.0,
    )
    cfg = dataclasses.replace(config, screw=screw)
    rng = np.random.default_rng(11)
    clipped = 0
    smooth = 0
    for base in solved.values():
        scene = make_scene(cfg, base.scene.temperature, base.scene.screw_speed)
        for size in (0.0, 1e-6, 3e-6):
            case = perturbed(dataclasses.replace(base, scene=scene), rng, size)
            ref = evaluate_contacts(*case.args())
            clipped += int(np.sum((ref.approach > 0.0) & ~ref.active))
            smooth += int(np.sum(np.isinf(ref.tallian)))
            check(case)
    assert clipped > 0 and smooth > 0


def test_degenerate_states(config: TwinConfig) -> None:
    """Centred balls touch nothing; deep approaches; zero rates; a ball on the helix axis side."""
    scene = make_scene(config, 293.15, 10.0)
    count = 6
    ball_nb = np.zeros((count, 2))
    ball_nb[1] = (0.0, 3e-5)
    ball_nb[2] = (2e-5, -2e-5)
    ball_nb[3] = (-2e-5, 1e-5)
    ball_nb[4] = (1e-4, 0.0)
    ball_nb[5] = (0.0, -1e-4)
    nut_offset = np.array([0.0, 6e-5, -4e-5, 1e-5, 0.0, -2e-4])
    kinematics = np.zeros((count, 4))
    kinematics[1:] = (-5.0, 100.0, -50.0, 30.0)
    gravity = np.tile((0.0, 0.0, -9.81), (count, 1))
    case = Case(scene, ball_nb, kinematics, nut_offset, gravity)
    ref = evaluate_contacts(*case.args())
    assert not ref.active[0].any() and ref.active.any()
    check(case)


def test_solver_can_switch_to_the_kernel(config: TwinConfig) -> None:
    """A steady solve with the kernel gives the reference solve's drag torque and state."""
    point = operating_point(100.0, 20.0, 1500.0)
    reference = SteadyStateModel(config, mode="symmetric").solve(point)
    compiled = solve_with_kernel(config, "symmetric", point)
    assert compiled.output.drag_torque == pytest.approx(reference.output.drag_torque, rel=1e-7)
    np.testing.assert_allclose(compiled.state.ball_nb, reference.state.ball_nb, rtol=1e-7)
    for name in steady.MECHANISMS:
        assert getattr(compiled.output.breakdown, name) == pytest.approx(
            getattr(reference.output.breakdown, name), rel=1e-7
        )


def test_full_mode_with_the_kernel_agrees_with_symmetric(
    solved: dict[tuple[str, str], Case],
) -> None:
    """Full (50 spheres) and symmetric states agree on a vertical screw (as in test_steady)."""
    for point in POINTS:
        sym = solved[(point, "symmetric")]
        full = solved[(point, "full")]
        np.testing.assert_allclose(full.ball_nb[0], sym.ball_nb[0], rtol=1e-5, atol=1e-12)
        np.testing.assert_allclose(full.ball_nb[-1], sym.ball_nb[1], rtol=1e-5, atol=1e-12)


def test_inputs_of_other_layouts_are_accepted(solved: dict[tuple[str, str], Case]) -> None:
    """Non-contiguous or integer-free views are copied into the kernel's layout."""
    base = solved[("20C-100rpm-1500N", "full")]
    wide = np.zeros((len(base.ball_nb), 4))
    wide[:, ::2] = base.ball_nb
    case = dataclasses.replace(base, ball_nb=wide[:, ::2])
    ref = evaluate_contacts(*case.args())
    got = evaluate_contacts_compiled(*case.args())
    compare(ref, got, case.scene)
