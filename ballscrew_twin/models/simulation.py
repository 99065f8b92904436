"""Run a :class:`~ballscrew_twin.models.scenario.Scenario` through the dynamic model.

:func:`simulate` builds the parameter set and the :class:`DynamicModel`, starts from the static
equilibrium at zero preload, steps to the end of the scenario and records

- every ``output_interval``: commands, screw speed, motor torque, the spheres' torque on the
  screw, nut forces and positions, dissipation (total, per mechanism, per nut), stored energy
  (kinetic, elastic, gravitational), the gravitational power and the power-balance error
  E(t) - E(0) - int_0^t (P_in - P_diss) dt (trapezoid over every step);
- every ``contact_output_interval``: the state of every sphere / half-groove contact;
- a summary over the last ``average_window`` (paper protocol, section 3): mean motor torque,
  gravity torque (mean gravitational power / mean speed), drag torque = mean motor torque -
  gravity torque, breakdown by mechanism (mean dissipation / mean speed), the drag's standard
  deviation over the window, the final power-balance error, wall time and real-time factor.

Every value is SI (s, rad/s, N m, N, m, W, J). The per-step means of the summary use every
integration step of the window, not only the recorded samples.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import SolverError
from ..params import TwinConfig, load_config
from ..physics.contact_types import ContactEvaluation
from .base import OperatingPoint
from .contact_forces import make_scene
from .dynamic import DynamicModel
from .dynamic_loop import ModelStep, StepPlan, TimeLoop
from .dynamic_state import Commands, DynamicState, StepReport
from .faults import faults_from_mapping
from .scenario import Scenario
from .simulation_result import MECHANISMS, SimulationResult
from .simulation_summary import run_summary, unconverged_summary
from .validity import ValidityEnvelope, refuse_outside

FloatArray = NDArray[np.float64]
ProgressCallback = Callable[[float, float], None]

#: Progress is reported about every this fraction of the run [-].
PROGRESS_FRACTION = 0.005


def build_config(scenario: Scenario) -> TwinConfig:
    """The scenario's parameter set, with ``balls_per_nut`` overridden when it is given."""
    config = load_config(scenario.config_path())
    count = scenario.balls_per_nut
    if count is not None:
        screw = replace(
            config.screw,
            balls_per_nut=count,
            balls_total_per_nut=max(count, config.screw.balls_total_per_nut),
        )
        screw.validate(f"{scenario.source or '<scenario>'}: balls_per_nut override")
        config = replace(config, screw=screw)
    return config


class _Recorder:
    """Preallocated buffers of the time series and contact samples."""

    def __init__(self, samples: int, contact_samples: int, balls: int) -> None:
        self.n = 0
        self.m = 0
        zeros = np.zeros
        self.series: dict[str, FloatArray] = {
            name: zeros(samples)
            for name in (
                "time",
                "speed_command",
                "preload_command",
                "screw_speed",
                "motor_torque",
                "screw_torque",
                "dissipation",
                "kinetic_energy",
                "elastic_energy",
                "gravitational_energy",
                "gravitational_power",
                "input_energy",
                "dissipated_energy",
                "power_balance_error",
            )
        }
        self.series["nut_force"] = zeros((samples, 2))
        self.series["nut_position"] = zeros((samples, 2))
        self.series["nut_dissipation"] = zeros((samples, 2))
        self.series["mechanism_dissipation"] = zeros((samples, len(MECHANISMS)))
        self.contacts: dict[str, FloatArray] = {"contact_time": zeros(contact_samples)}
        for name in (
            "normal_force",
            "friction_force",
            "contact_angle",
            "tallian",
            "film_thickness",
            "slip",
            "max_pressure",
            "semi_axis_x",
            "semi_axis_y",
            "lubricant_share",
            "dry_share",
        ):
            self.contacts[name] = zeros((contact_samples, balls, 4))
        self.in_contact = np.zeros((contact_samples, balls, 4), dtype=bool)

    def trimmed(self) -> tuple[dict[str, Any], dict[str, Any], NDArray[np.bool_]]:
        """The filled part of every buffer (values are float arrays)."""
        series = {k: v[: self.n] for k, v in self.series.items()}
        contacts = {k: v[: self.m] for k, v in self.contacts.items()}
        return series, contacts, self.in_contact[: self.m]


def _gravitational_power(model: DynamicModel, ball_mass: float, state: DynamicState) -> float:
    """d/dt of :meth:`DynamicModel.energy`'s gravitational term at ``state`` [W]."""
    power = -ball_mass * float(np.sum(state.ball_velocity @ model.gravity))
    if model.config.screw.orientation == "vertical":
        power += (
            model.config.screw.nut_mass
            * model.config.environment.gravity
            * float(np.sum(state.nut_velocity))
        )
    return power


def simulate(
    scenario: Scenario, progress: ProgressCallback | None = None, *, compiled_loop: bool = True
) -> SimulationResult:
    """Run ``scenario`` through the dynamic model and record its outputs.

    Args:
        scenario: the validated scenario.
        progress: called as ``progress(fraction_done, elapsed_wall_seconds)`` about every 0.5 %
            of the run and once at the end.
        compiled_loop: with the compiled step, run the steps between two records in one
            compiled call (kernels/dynamic_run.run_steps); False: one Python iteration per step
            (the reference, tested equal). Ignored when the model runs the Python step.

    Raises:
        ConfigError: the parameter file or the ``balls_per_nut`` override is invalid.
        SolverError: the dynamic model produced a non-finite value (time and quantity named).
    """
    started = time.perf_counter()
    started_unix_ns = time.time_ns()
    config = build_config(scenario)
    command = OperatingPoint(
        screw_speed=scenario.speed, temperature=scenario.temperature, preload=scenario.preload
    )
    refuse_outside([command], ValidityEnvelope.for_config(config), scenario.source or "scenario")
    model = DynamicModel(
        config,
        scenario.temperature,
        time_step=scenario.time_step,
        jacobian_interval=scenario.jacobian_interval,
        controller=scenario.controller,
        backend=scenario.backend,
        sphere_contacts=scenario.sphere_contacts,
        implicit_positions=scenario.implicit_positions,
        faults=faults_from_mapping(
            scenario.faults, config.screw.balls_per_nut, f"{scenario.source or 'scenario'}: faults"
        ),
    )
    run = _Run(scenario, model, progress, started)
    if compiled_loop and model._kernel is not None:
        run.compiled()
    else:
        run.python()
    wall = time.perf_counter() - started
    if progress is not None:
        progress(1.0, wall)
    series, contacts, in_contact = run.rec.trimmed()
    nut_members = [model.ball_nut == k for k in (0, 1)]
    ball_index = np.concatenate([np.arange(int(m.sum())) for m in nut_members]).astype(np.int64)
    result = SimulationResult(
        scenario=scenario,
        **series,
        **contacts,
        in_contact=in_contact,
        ball_nut=model.ball_nut.astype(np.int64),
        ball_index=ball_index,
        screw_inertia=config.screw.screw_inertia,
    )
    steps = scenario.steps
    result.summary = run_summary(
        result,
        run.window,
        run.window_mechanisms,
        run.window_nuts,
        run.abs_input_energy,
        wall,
        steps,
        config,
    )
    result.summary["start_time_unix_ns"] = started_unix_ns
    result.summary["unconverged_steps"] = model.unconverged_steps
    result.summary["fallback_steps"] = run.fallbacks
    result.summary["unconverged"] = unconverged_summary(
        run.unconverged, model.unconverged_steps, steps, scenario
    )
    result.summary["work_per_step"] = {
        name: count / max(steps + 1, 1) for name, count in model.work.items()
    }
    return result


class _Run:
    """A run of :func:`simulate`: the model's one time loop (:class:`TimeLoop`) with this run's
    hook, or its compiled form, one call per record interval (kernels/dynamic_run.py).

    Both visit steps k = 0 .. steps (the last one only for its report) on the same
    :class:`StepPlan`, accumulate the energy integrals and window sums the same way and record
    every ``output_interval`` and ``contact_output_interval``.
    """

    def __init__(
        self,
        scenario: Scenario,
        model: DynamicModel,
        progress: ProgressCallback | None,
        started: float,
    ) -> None:
        self.scenario = scenario
        self.model = model
        self.progress = progress
        self.started = started
        self.ball_mass = make_scene(model.config, scenario.temperature, 0.0).ball_mass
        self.state = model.initial_state(0.0)
        self.steps = scenario.steps
        # The start phase: its steps of time_step are each run as ``substeps`` semi-implicit
        # steps of fine_time_step; from step ``fine_steps`` on, time_step with the scenario's
        # treatment of the positions. With implicit sphere positions, a step that does not
        # converge is redone from its start as ``fallback`` semi-implicit steps of
        # fine_time_step, with its commands.
        self.plan = StepPlan(
            time_step=scenario.time_step,
            implicit_positions=scenario.implicit_positions,
            fine_time_step=scenario.fine_time_step,
            fine_steps=scenario.fine_steps,
            substeps=scenario.substeps,
            fallback=scenario.fallback_substeps,
        )
        self.fallbacks = 0  # run steps redone as fallback substeps
        self.plan.start(model)
        self.every = scenario.steps_per(scenario.output_interval)
        self.contact_every = scenario.steps_per(scenario.contact_output_interval)
        self.window_first = self.steps - scenario.steps_per(scenario.average_window)
        balls = len(model.ball_nut)
        self.rec = _Recorder(
            self.steps // self.every + 1, self.steps // self.contact_every + 1, balls
        )
        self.progress_every = max(1, round(self.steps * PROGRESS_FRACTION))
        self.total0 = float(sum(model.energy(self.state).values()))
        self.abs_input_energy = 0.0
        # The Python loop's energy integrals so far [J] and the (input power [W], dissipation
        # [W], length [s]) of its last step.
        self.input_energy = self.dissipated = 0.0
        self.previous: tuple[float, float, float] | None = None
        self.window = {"motor": 0.0, "speed": 0.0, "gravity": 0.0, "count": 0}
        self.window_mechanisms = np.zeros(len(MECHANISMS))
        self.window_nuts = np.zeros(2)
        # Steps whose Newton iterations ended above STEP_TOLERANCE: (step index, its final
        # scaled residual).
        self.unconverged: list[tuple[int, float]] = []

    def _record(
        self,
        t: float,
        commands: Commands,
        state: DynamicState,
        motor: float,
        report: StepReport,
        p_grav: float,
        energies: tuple[float, float],
        contacts: ContactEvaluation | None = None,
    ) -> None:
        """Store the sample of step ``t`` [s]: ``energies`` = (input, dissipated) [J] so far;
        ``contacts``: the contact laws at ``state``'s positions when already evaluated."""
        energy = self.model.energy(state, contacts)
        input_energy, dissipated = energies
        i = self.rec.n
        s = self.rec.series
        s["time"][i] = t
        s["speed_command"][i] = commands.screw_speed
        s["preload_command"][i] = commands.preload
        s["screw_speed"][i] = state.screw_speed
        s["motor_torque"][i] = motor
        s["screw_torque"][i] = report.screw_torque
        s["nut_force"][i] = report.nut_force
        s["nut_position"][i] = state.nut_position
        s["dissipation"][i] = report.dissipation
        s["mechanism_dissipation"][i] = report.mechanism_dissipation
        s["nut_dissipation"][i] = report.nut_dissipation
        s["kinetic_energy"][i] = energy["kinetic"]
        s["elastic_energy"][i] = energy["elastic"]
        s["gravitational_energy"][i] = energy["gravitational"]
        s["gravitational_power"][i] = p_grav
        s["input_energy"][i] = input_energy
        s["dissipated_energy"][i] = dissipated
        s["power_balance_error"][i] = (
            float(sum(energy.values())) - self.total0 - input_energy + dissipated
        )
        self.rec.n += 1

    def python(self) -> None:
        """One Python iteration per step of the model (the reference loop, :class:`TimeLoop`):
        the energy integrals over every step, the samples at each run step's start."""
        loop = TimeLoop(
            self.model,
            self.state,
            self.plan,
            self.scenario.commands_at,
            self._visit,
            self._progress if self.progress is not None else None,
        )
        loop.run(self.steps, final_report=True)
        self.fallbacks = loop.fallbacks
        self.unconverged = loop.unconverged

    def _visit(self, step: ModelStep) -> None:
        """Accumulate the energy integrals (trapezoid) over the model ``step`` from its start
        state; sample at the start of each run step (its substep 0)."""
        state, commands, motor, report = step.state, step.commands, step.motor, step.report
        power_in = self.model.input_power(state, commands, motor)
        diss = report.dissipation
        previous = self.previous
        if previous is not None:
            interval = previous[2]
            self.input_energy += 0.5 * interval * (previous[0] + power_in)
            self.abs_input_energy += 0.5 * interval * (abs(previous[0]) + abs(power_in))
            self.dissipated += 0.5 * interval * (previous[1] + diss)
        self.previous = (power_in, diss, step.length)
        if step.j == 0:
            energies = (self.input_energy, self.dissipated)
            self._sample(step.k, commands, state, motor, report, energies)

    def _progress(self, done: int) -> None:
        """Report progress after ``done`` run steps, about every PROGRESS_FRACTION."""
        assert self.progress is not None  # only called with a callback
        if done % self.progress_every == 0:
            self.progress(done / self.steps, time.perf_counter() - self.started)

    def _sample(
        self,
        k: int,
        commands: Commands,
        state: DynamicState,
        motor: float,
        report: StepReport,
        energies: tuple[float, float],
    ) -> None:
        """The Python loop's window sums and records at the start of run step ``k``."""
        window = self.window
        t = k * self.scenario.time_step
        p_grav = _gravitational_power(self.model, self.ball_mass, state)
        if k >= self.window_first:
            window["motor"] += motor
            window["speed"] += state.screw_speed
            window["gravity"] += p_grav
            window["count"] += 1
            self.window_mechanisms += report.mechanism_dissipation
            self.window_nuts += report.nut_dissipation
        if k % self.every == 0:
            self._record(t, commands, state, motor, report, p_grav, energies)
        if k % self.contact_every == 0:
            _record_contacts(self.rec, report, t)

    def _note_unconverged(self, kr: Any, step: int, acc: FloatArray, done: int) -> None:
        """Record step ``step``, just run alone by the compiled loop, if it ended unconverged
        (``done``: the unconverged count before it)."""
        if acc[kr.A_UNCONVERGED] > done:
            self.unconverged.append((step, float(acc[kr.A_RESIDUAL])))

    def _replay(
        self,
        kr: Any,
        steps_from: Callable[[int, int], tuple[Any, Any]],
        k: int,
        n: int,
        first_stats: FloatArray,
        acc: FloatArray,
    ) -> tuple[Any, Any]:
        """Run steps k .. k + n - 1 one compiled call each, noting every unconverged step;
        return the first step's contact arrays and leave ``first_stats`` and the first-step
        accumulators as one call over the stretch leaves them."""
        firsts = (kr.A_FIRST_GRAVITY, kr.A_FIRST_INPUT, kr.A_FIRST_DISSIPATED)
        kept: tuple[Any, Any] | None = None
        saved_stats, saved_firsts = first_stats, acc[list(firsts)]
        for step in range(k, k + n):
            done = int(acc[kr.A_UNCONVERGED])
            out = steps_from(step, step + 1)
            if acc[kr.A_FAILED]:
                return out
            self._note_unconverged(kr, step, acc, done)
            if kept is None:
                kept, saved_stats, saved_firsts = out, first_stats.copy(), acc[list(firsts)]
        first_stats[:] = saved_stats
        acc[list(firsts)] = saved_firsts
        assert kept is not None
        return kept

    def compiled(self) -> None:
        """One compiled call (run_steps) per stretch of steps between two records (or two
        progress reports); a stretch with unconverged steps is replayed step by step."""
        from ..kernels import dynamic_layouts as kl
        from ..kernels import dynamic_run as kr
        from ..kernels.contacts import evaluation_from_buffer

        kr.ensure_fresh_cache()
        model, scenario, state, plan = self.model, self.scenario, self.state, self.plan
        kernel = model._kernel
        assert kernel is not None
        dt, steps = scenario.time_step, self.steps
        count = len(model.ball_nut)
        pos = np.array(state.ball_position, dtype=np.float64)
        vel = np.array(state.ball_velocity, dtype=np.float64)
        omega = np.array(state.ball_omega, dtype=np.float64)
        theta = np.array(state.helix_parameter, dtype=np.float64)
        body = np.array(
            [
                state.time,
                state.screw_angle,
                state.screw_speed,
                state.controller_integral,
                *state.nut_position,
                *state.nut_velocity,
            ],
            dtype=np.float64,
        )
        jam_start = np.full(count, math.inf)
        for jam in model.faults.jams:
            hit = (model.ball_nut == jam.nut) & (model.ball_index == jam.index)
            jam_start[hit] = np.minimum(jam_start[hit], jam.start)
        acc = np.zeros(kr.A_COUNT)
        first_stats = np.zeros(kl.S_COUNT)
        jacobian = (
            kernel.jac_own,
            kernel.jac_shared,
            kernel.jac_active,
            kernel.jac_meta,
            kernel.history,
            kernel.history_meta,
        )
        done = [0, 0, 0, 0]  # evaluations, Jacobians, iterations, unconverged already counted
        k = 0
        while k <= steps:
            record = k % self.every == 0
            record_contacts = k % self.contact_every == 0
            stop = min(
                (k // self.every + 1) * self.every,
                (k // self.contact_every + 1) * self.contact_every,
                (k // self.progress_every + 1) * self.progress_every,
                steps,
                plan.fine_steps if k < plan.fine_steps else steps,
            )
            n = 1 if k == steps else stop - k
            parts, step = plan.parts(model, k)
            times = _step_times(k, n, dt, parts, step)
            commands = np.empty((len(times), 2))
            commands[:, 0] = scenario.speed_profile.at(times)
            commands[:, 1] = scenario.preload_profile.at(times)
            motor = float(acc[kr.A_MOTOR])
            before = _body_state(pos, vel, omega, theta, body) if record else None
            mutable = (pos, vel, omega, theta, body, acc, *jacobian)
            snapshot = [a.copy() for a in mutable]

            # Steps of the start phase are before the window and the run's end (Scenario
            # validation), and the kernel counts their substeps: neither index applies there.
            window_first = self.window_first if parts == 1 else sys.maxsize
            final_step = steps if parts == 1 else -1

            def steps_from(
                first: int,
                last: int,
                commands: FloatArray = commands,
                k: int = k,
                parts: int = parts,
                window_first: int = window_first,
                final_step: int = final_step,
            ) -> tuple[Any, Any]:
                return kr.run_steps(
                    first, window_first, final_step,
                    commands[(first - k) * parts : (last - k) * parts], pos,
                    vel, omega, theta, body, kernel.ball_nut, kernel.consts, kernel.params,
                    kernel.sphere_offset, kernel.spalls, jam_start, *jacobian, acc, first_stats,
                    plan.fallback if parts == 1 else 1, scenario.fine_time_step or dt,
                )  # fmt: skip

            active, buffer = steps_from(k, k + n)
            if acc[kr.A_UNCONVERGED] > done[3] and n > 1 and not acc[kr.A_FAILED]:
                # Replay the stretch one step at a time from the snapshot (same arithmetic,
                # same state) to locate each unconverged step and keep its residual.
                for array, saved in zip(mutable, snapshot, strict=True):
                    array[...] = saved
                active, buffer = self._replay(kr, steps_from, k, n, first_stats, acc)
            else:
                self._note_unconverged(kr, k, acc, done[3])  # n == 1 or nothing new
            if acc[kr.A_FAILED] > 0.0:
                # body is left at the start of the failed step
                failed_at = acc[kr.A_FAILED_STEP] * dt if parts == 1 else body[kl.B_TIME]
                raise SolverError(
                    f"dynamic model diverged at t = {failed_at:.7g} s: "
                    f"{kr.FINITE_CHECKS[int(acc[kr.A_FAILED]) - 1]} is "
                    f"{acc[kr.A_FAILED_VALUE]} (last screw speed {body[kl.B_SPEED]:.6g} rad/s)"
                )
            totals = [
                int(acc[kr.A_EVALS]),
                int(acc[kr.A_JACOBIANS]),
                int(acc[kr.A_ITERATIONS]),
                int(acc[kr.A_UNCONVERGED]),
            ]
            work = model.work
            work["contact_evaluations"] += totals[0] - done[0]
            work["jacobians"] += totals[1] - done[1]
            work["newton_iterations"] += totals[2] - done[2]
            model.unconverged_steps += totals[3] - done[3]
            model.last_step_residual = float(acc[kr.A_RESIDUAL])
            done = totals
            if record or record_contacts:
                # The first step's contacts: at the positions of ``before`` (semi-implicit) or
                # at its end (implicit positions; the record's energy is then evaluated anew).
                contacts = evaluation_from_buffer(active, buffer)
                report = _report_from_stats(kl, first_stats, contacts)
                t = k * dt
                if record:
                    assert before is not None
                    self._record(
                        t,
                        Commands(float(commands[0, 0]), float(commands[0, 1])),
                        before,
                        motor,
                        report,
                        float(acc[kr.A_FIRST_GRAVITY]),
                        (float(acc[kr.A_FIRST_INPUT]), float(acc[kr.A_FIRST_DISSIPATED])),
                        None if model.implicit_positions else contacts,
                    )
                if record_contacts:
                    _record_contacts(self.rec, report, t)
            k += n
            if self.progress is not None and k % self.progress_every == 0 and k <= steps:
                self.progress(k / steps, time.perf_counter() - self.started)
        window = self.window
        window["motor"] = float(acc[kr.A_W_MOTOR])
        window["speed"] = float(acc[kr.A_W_SPEED])
        window["gravity"] = float(acc[kr.A_W_GRAVITY])
        window["count"] = int(acc[kr.A_W_COUNT])
        self.window_mechanisms = acc[kr.A_W_MECHANISMS : kr.A_W_MECHANISMS + len(MECHANISMS)].copy()
        self.window_nuts = acc[kr.A_W_NUTS : kr.A_W_NUTS + 2].copy()
        self.abs_input_energy = float(acc[kr.A_ABS_INPUT])
        self.fallbacks = int(acc[kr.A_FALLBACKS])


def _step_times(k: int, n: int, dt: float, parts: int, step: float) -> FloatArray:
    """Start times [s] of the model's steps in run steps k .. k + n - 1 of ``dt`` [s], each
    run as ``parts`` steps of ``step`` [s] (the Python loop's arithmetic)."""
    starts = np.arange(k, k + n, dtype=np.float64) * dt
    if parts == 1:
        return starts
    return np.asarray((starts[:, None] + np.arange(parts) * step).ravel())


def _body_state(
    pos: FloatArray, vel: FloatArray, omega: FloatArray, theta: FloatArray, body: FloatArray
) -> DynamicState:
    """A :class:`DynamicState` copy of the compiled loop's arrays (layout of step_kernel)."""
    return DynamicState(
        time=float(body[0]),
        screw_angle=float(body[1]),
        screw_speed=float(body[2]),
        controller_integral=float(body[3]),
        nut_position=body[4:6].copy(),
        nut_velocity=body[6:8].copy(),
        ball_position=pos.copy(),
        ball_velocity=vel.copy(),
        ball_omega=omega.copy(),
        helix_parameter=theta.copy(),
    )


def _report_from_stats(kl: Any, stats: FloatArray, contacts: Any) -> StepReport:
    """The :class:`StepReport` of a step from step_kernel's statistics (layout kl.S_*)."""
    return StepReport(
        motor_torque=float(stats[kl.S_MOTOR]),
        contacts=contacts,
        nut_force=stats[kl.S_NUT_FORCE : kl.S_NUT_FORCE + 2].copy(),
        screw_torque=float(stats[kl.S_SCREW_TORQUE]),
        dissipation=float(stats[kl.S_DISSIPATION]),
        mechanism_dissipation=stats[kl.S_MECHANISMS : kl.S_MECHANISMS + kl.N_MECHANISMS].copy(),
        nut_dissipation=stats[kl.S_NUT_DISSIPATION : kl.S_NUT_DISSIPATION + 2].copy(),
    )


def _record_contacts(rec: _Recorder, report: StepReport, t: float) -> None:
    """Store the contact states of one step's start (time ``t`` [s])."""
    ev = report.contacts
    j = rec.m
    c = rec.contacts
    active = ev.active
    c["contact_time"][j] = t
    c["normal_force"][j] = np.where(
        active, ev.hertz.stiffness * np.maximum(ev.approach, 0.0) ** 1.5, 0.0
    )
    friction = ev.friction_lubricant + ev.friction_dry
    c["friction_force"][j] = np.where(active, friction, 0.0)
    c["contact_angle"][j] = ev.contact_angle
    c["tallian"][j] = ev.tallian
    c["film_thickness"][j] = ev.film_total
    c["slip"][j] = ev.slip
    c["max_pressure"][j] = np.where(active, ev.hertz.max_pressure, 0.0)
    c["semi_axis_x"][j] = np.where(active, ev.hertz.semi_axis_x, 0.0)
    c["semi_axis_y"][j] = np.where(active, ev.hertz.semi_axis_y, 0.0)
    safe = np.where(friction > 0.0, friction, 1.0)
    c["lubricant_share"][j] = np.where(active & (friction > 0.0), ev.friction_lubricant / safe, 0.0)
    c["dry_share"][j] = np.where(active & (friction > 0.0), ev.friction_dry / safe, 0.0)
    rec.in_contact[j] = active
    rec.m += 1
