"""Property tests of the steady-state model across and beyond the operating envelope.

Preload 0-5000 N, speed -6000..6000 rpm, temperature -40..100 C: every solve either converges to
a physically admissible state (finite, non-negative forces and films, no mechanism generating
power, power balance closed) or raises a SolverError that says it did not converge. It never
hangs (iterations and continuation stages are bounded) and never returns garbage.
"""

import math

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from ballscrew_twin.errors import SolverError
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import MECHANISMS, SteadySolution, SteadyStateModel
from ballscrew_twin.models.steady_problem import residual_scales
from ballscrew_twin.params import load_config
from ballscrew_twin.physics import geometry

CONFIG = load_config()
#: Terms of a sum accumulate at most this many roundings each (summation bound n eps sum |x|,
#: with a margin for the few products behind every term) [-].
ROUNDINGS_PER_TERM = 16


def residual_torque_bound(model: SteadyStateModel, sol: SteadySolution) -> float:
    """Largest |direct - gravity - drag| torque the solver's stop allows [N m].

    At the exact equilibrium the work-energy identity holds; at the Newton stop every sphere is
    left with a net force R_F and moment R_M (each component at most ``sol.residual`` times the
    force or moment scale) and every nut with a net axial force (at most ``sol.residual`` times
    the nut scale). Their power, R_F . v + R_M . omega on each sphere (centre velocity v and
    absolute angular velocity omega) and R_nut v_nut on each nut, is what the balance misses;
    divided by the screw speed it is a torque that does not shrink with the speed, while the
    drag torque does (near-zero speed). Round-off of the sums of moments and powers is added.
    """
    op = sol.output.operating_point
    speed = op.screw_speed
    scene = model.scene(op.temperature, speed)
    loads = model.nut_axial_loads(op)
    force_scale, moment_scale = residual_scales(model.config, scene, loads)
    geom = scene.geometry
    lead_rate = geom.lead / (2.0 * math.pi)  # m of axial travel per rad
    zhat = geometry.axis_direction(geom.helix_angle)
    state = sol.state
    # |v| <= |w_B + Omega| |r| + |w_B| lead / (2 pi): orbit about the axis plus travel along it.
    radius = np.hypot(state.ball_nb[:, 0] - geom.pitch_radius, state.ball_nb[:, 1])
    orbit = state.kinematics[:, 0]
    centre_speed = np.abs(orbit + speed) * radius + np.abs(orbit) * lead_rate
    spin_rate = np.linalg.norm(state.kinematics[:, 1:] + speed * zhat, axis=1)
    vector = math.sqrt(3.0) * sol.residual  # |3-vector| <= sqrt(3) max |component|
    sphere_power = vector * (force_scale * centre_speed + moment_scale * spin_rate)
    nut_force = sol.residual * force_scale * model.config.screw.balls_per_nut
    power = (
        float(np.sum(sol.balls.weight * sphere_power)) + 2.0 * nut_force * abs(speed) * lead_rate
    )
    weight = sol.balls.weight[:, None]
    magnitude = float(np.sum(np.abs(sol.contacts.groove_moment_z) * weight))
    magnitude += abs(sol.gravity_torque) + sum(
        float(np.sum(np.abs(sol.contacts.dissipation[m]) * weight)) for m in MECHANISMS
    ) / abs(speed)
    terms = sol.contacts.groove_moment_z.size * len(MECHANISMS)
    return power / abs(speed) + ROUNDINGS_PER_TERM * terms * np.finfo(float).eps * magnitude


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
# Failed with the former tolerance (1e-9 of the torque scale): the balance then missed 4.6e-12
# N m of residual power over a drag of 3.2e-6 N m against an allowance of 4.3e-12 N m.
@example(preload=3661.5, rpm=6.12e-5, celsius=0.0)
@given(
    preload=st.floats(0.0, 5000.0),
    rpm=st.floats(-6000.0, 6000.0),
    celsius=st.floats(-40.0, 100.0),
)
def test_admissible_state_or_clear_error(preload: float, rpm: float, celsius: float) -> None:
    point = OperatingPoint(
        screw_speed=rpm * 2 * math.pi / 60, temperature=celsius + 273.15, preload=preload
    )
    # Tight solver tolerance: the work-energy identity below holds to round-off at the exact
    # solution and to the power of the residual left by the Newton stop (bounded below).
    model = SteadyStateModel(CONFIG, tolerance=1e-12)
    try:
        sol = model.solve(point)
    except SolverError as err:
        assert "did not converge" in str(err)
        return
    out = sol.output
    cs = out.contacts
    assert cs is not None
    for name in (
        "normal_force",
        "friction_force",
        "film_thickness",
        "max_pressure",
        "tallian_parameter",
        "shear_stress",
        "slip_speed",
    ):
        values = getattr(cs, name)
        assert np.all(np.isfinite(values)), name
        assert np.all(values >= 0.0), name
    assert np.all(cs.film_thickness[cs.in_contact] > 0.0) or point.screw_speed == 0.0
    # Second law: the contacts dissipate in total; each law that is dissipative by construction
    # (friction, spin, hysteresis, curvature) does so on its own. The hydrodynamic FR pair of
    # Eq. 41 may return power while a barely loaded sphere skids (docs/model.md, D13).
    power = {
        m: float(np.sum(sol.contacts.dissipation[m] * sol.balls.weight[:, None]))
        for m in MECHANISMS
    }
    assert all(math.isfinite(p) for p in power.values())
    assert sum(power.values()) >= 0.0
    for name in ("lubricant_shear", "dry_contact", "hysteresis", "curvature", "spin"):
        assert power[name] >= 0.0, name
    if sol.state.screw_speed != 0.0:  # not solved as standstill
        # Work-energy balance: screw torque less the torque lifting the nuts is the dissipation.
        assert sol.residual < model.tolerance
        balance = sol.screw_torque_direct - sol.gravity_torque
        assert abs(balance - out.drag_torque) <= residual_torque_bound(model, sol)


def test_zero_speed_zero_preload_is_defined() -> None:
    out = SteadyStateModel(CONFIG).evaluate(
        OperatingPoint(screw_speed=0.0, temperature=293.15, preload=0.0)
    )
    assert out.drag_torque == 0.0
    assert any("zero speed" in n for n in out.notes)


def test_creeping_speed_is_solved_as_standstill() -> None:
    point = OperatingPoint(screw_speed=1.5e-295, temperature=273.15, preload=62.0)
    out = SteadyStateModel(CONFIG).evaluate(point)
    assert out.drag_torque == 0.0
    assert out.operating_point == point
    assert any("standstill" in n for n in out.notes)
