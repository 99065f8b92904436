"""Writers of a run of the dynamic model (a
:class:`~ballscrew_twin.models.simulation_result.SimulationResult`): CSV, NPZ, rosbag2, PNG.

- :func:`write_csv`: the time series, one row per output sample, units in the header.
- :func:`write_npz`: every array, plus the summary and the scenario as JSON strings.
- :func:`write_bag`: a rosbag2 (MCAP or SQLite3) with ``/drag_torque``
  (``ballscrew_twin_msgs/msg/DragTorque``) at every output sample and ``/contact_states``
  (``ballscrew_twin_msgs/msg/ContactStateArray``) at every contact sample, written with the
  pure-Python ``rosbags`` library (0.11); the custom message definitions are read from
  ``msg_defs/msg/*.msg`` and stored in the bag, so any reader can decode them. Bag times and
  header stamps are the run's wall-clock start (``summary["start_time_unix_ns"]``) plus the
  simulated time, in integer nanoseconds; the metadata name the ROS distribution (jazzy,
  :mod:`ballscrew_twin.bags.writer`).
- :func:`plot_result`: speed, motor torque and drag over time, and the power-balance error.
- :func:`plot_contacts`: the contact states per sphere of each nut at the last contact sample
  (normal force, contact angle, film thickness, Tallian parameter; screw and nut side).

SI units throughout (REP 103).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .errors import BallscrewTwinError, ResultsError
from .models.base import MECHANISMS as BREAKDOWN_FIELDS
from .models.simulation_result import MECHANISMS, SimulationResult
from .units import CELSIUS_ZERO, SCREW_FRAME_ID, ns_to_stamp

DRAG_TOPIC = "/drag_torque"
CONTACT_TOPIC = "/contact_states"
FIDELITY = "dynamic"


def _columns(result: SimulationResult) -> list[tuple[str, np.ndarray]]:
    """(header with unit, column) of every time series."""
    columns: list[tuple[str, np.ndarray]] = [
        ("time [s]", result.time),
        ("speed_command [rad/s]", result.speed_command),
        ("preload_command [N]", result.preload_command),
        ("screw_speed [rad/s]", result.screw_speed),
        ("motor_torque [N m]", result.motor_torque),
        ("gravity_torque [N m]", result.gravity_torque),
        ("drag_torque [N m]", result.drag_torque),
        ("screw_torque_contacts [N m]", result.screw_torque),
        ("nut_force_master [N]", result.nut_force[:, 0]),
        ("nut_force_slave [N]", result.nut_force[:, 1]),
        ("nut_position_master [m]", result.nut_position[:, 0]),
        ("nut_position_slave [m]", result.nut_position[:, 1]),
        ("dissipation_reported [W]", result.dissipation),
    ]
    columns += [
        (f"dissipation_reported_{name} [W]", result.mechanism_dissipation[:, k])
        for k, name in enumerate(MECHANISMS)
    ]
    columns += [
        ("kinetic_energy [J]", result.kinetic_energy),
        ("elastic_energy [J]", result.elastic_energy),
        ("gravitational_energy [J]", result.gravitational_energy),
        ("gravitational_power [W]", result.gravitational_power),
        ("input_energy [J]", result.input_energy),
        ("dissipated_energy [J]", result.dissipated_energy),
        ("power_balance_error [J]", result.power_balance_error),
    ]
    return columns


def write_csv(result: SimulationResult, path: str | Path) -> Path:
    """The time series as CSV, one row per output sample, units in the header.

    Values are written with 17 significant digits, so they read back exactly. The
    ``dissipation_reported*`` columns are the contact laws' dissipation at the start of each
    step, not yet consistent with the work of the implicit step (docs/model.md section 10).
    """
    file = Path(path)
    columns = _columns(result)
    try:
        with file.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow([name for name, _ in columns])
            for i in range(len(result.time)):
                writer.writerow([f"{float(values[i]):.17g}" for _, values in columns])
    except OSError as err:
        raise ResultsError(f"{file}: cannot write CSV ({err.strerror})") from err
    return file


def _echo(result: SimulationResult) -> dict[str, Any]:
    """Summary and scenario as a JSON-ready mapping."""
    scenario = dataclasses.asdict(result.scenario)
    return {"summary": result.summary, "scenario": scenario}


def summary_json(result: SimulationResult) -> str:
    """The summary and the scenario that made it, as JSON (SI units)."""
    return json.dumps(_echo(result), indent=2, default=str, allow_nan=True)


def write_npz(result: SimulationResult, path: str | Path) -> Path:
    """Every array of the result, the mechanism names and ``summary_json`` (a JSON string)."""
    file = Path(path)
    arrays: dict[str, Any] = {
        f.name: getattr(result, f.name)
        for f in dataclasses.fields(result)
        if isinstance(getattr(result, f.name), np.ndarray)
    }
    arrays["mechanisms"] = np.array(MECHANISMS)
    arrays["summary_json"] = np.array(summary_json(result))
    try:
        with file.open("wb") as handle:
            np.savez(handle, **arrays)
    except OSError as err:
        raise ResultsError(f"{file}: cannot write NPZ ({err.strerror})") from err
    return file


def _nanoseconds(seconds: float) -> int:
    """Simulated time as integer nanoseconds (bag and header time)."""
    return round(seconds * 1e9)


def _stamp(store: Any, t_ns: int) -> Any:
    """builtin_interfaces/Time of ``t_ns``."""
    time_cls = store.types["builtin_interfaces/msg/Time"]
    sec, nanosec = ns_to_stamp(t_ns)
    return time_cls(sec=sec, nanosec=nanosec)


def write_bag(
    result: SimulationResult,
    path: str | Path,
    storage: str = "mcap",
    msg_dir: str | Path | None = None,
) -> Path:
    """A rosbag2 with ``/drag_torque`` and ``/contact_states`` of the run.

    Args:
        result: the simulation result.
        path: the bag folder to create (must not exist).
        storage: ``"mcap"`` or ``"sqlite3"``.
        msg_dir: folder of the ``*.msg`` definitions (default: the package's, msg_defs/msg).

    ``DragTorque.total`` is the motor torque minus the gravity torque at that sample; the
    breakdown is each mechanism's dissipation / screw speed and the per-nut torques each nut's
    dissipation / speed (0 at standstill; the normal damping of Eqs. 18-19 has no field and is
    only in the CSV/NPZ outputs). ``real_time_factor`` is simulated time per wall time (>= 1
    keeps up).
    """
    from .bags.writer import MSG_DIR, MSG_PACKAGE, BagWriter, project_typestore, storage_plugin

    plugin = storage_plugin(storage, ResultsError)
    store = project_typestore(MSG_DIR if msg_dir is None else msg_dir)
    folder = Path(path)
    if folder.exists():
        raise ResultsError(f"{folder}: bag folder exists already")
    types = store.types
    drag_cls = types[f"{MSG_PACKAGE}/msg/DragTorque"]
    array_cls = types[f"{MSG_PACKAGE}/msg/ContactStateArray"]
    state_cls = types[f"{MSG_PACKAGE}/msg/ContactState"]
    header_cls = types["std_msgs/msg/Header"]
    sc = result.scenario
    rtf = float(result.summary.get("real_time_factor", 0.0))
    start_ns = int(result.summary.get("start_time_unix_ns", 0))
    drag = result.drag_torque
    breakdown = result.breakdown_torque()
    nut_torque = result.nut_torque()
    index = {name: k for k, name in enumerate(MECHANISMS)}
    try:
        with BagWriter(folder, plugin) as writer:
            drag_conn = writer.add_connection(DRAG_TOPIC, drag_cls.__msgtype__, typestore=store)
            contact_conn = writer.add_connection(
                CONTACT_TOPIC, array_cls.__msgtype__, typestore=store
            )
            for i, t in enumerate(result.time):
                t_ns = start_ns + _nanoseconds(float(t))
                msg = drag_cls(
                    header=header_cls(stamp=_stamp(store, t_ns), frame_id=SCREW_FRAME_ID),
                    total=float(drag[i]),
                    nut_master=float(nut_torque[i, 0]),
                    nut_slave=float(nut_torque[i, 1]),
                    **{name: float(breakdown[i, index[name]]) for name in BREAKDOWN_FIELDS},
                    fidelity=FIDELITY,
                    real_time_factor=float(rtf) if math.isfinite(rtf) else 0.0,
                    screw_speed=float(result.screw_speed[i]),
                    temperature=float(sc.temperature) - CELSIUS_ZERO,
                    preload=float(result.preload_command[i]),
                    axial_load=0.0,  # the dynamic scenarios apply no external axial load
                )
                writer.write(drag_conn, t_ns, store.serialize_cdr(msg, drag_cls.__msgtype__))
            for j, t in enumerate(result.contact_time):
                t_ns = start_ns + _nanoseconds(float(t))
                states = _contact_states(result, j, state_cls)
                msg = array_cls(
                    header=header_cls(stamp=_stamp(store, t_ns), frame_id=SCREW_FRAME_ID),
                    fidelity=FIDELITY,
                    contacts=states,
                )
                writer.write(contact_conn, t_ns, store.serialize_cdr(msg, array_cls.__msgtype__))
    except OSError as err:
        raise ResultsError(f"{folder}: cannot write bag ({err.strerror})") from err
    return folder


def _contact_states(result: SimulationResult, j: int, state_cls: Any) -> list[Any]:
    """One ContactState per sphere and half groove in contact at contact sample ``j``."""
    states = []
    balls, grooves = np.nonzero(result.in_contact[j])
    for b, g in zip(balls.tolist(), grooves.tolist(), strict=True):
        states.append(
            state_cls(
                sphere_index=int(result.ball_index[b]),
                nut=int(result.ball_nut[b]),
                half_groove=int(g),
                in_contact=True,
                normal_force=float(result.normal_force[j, b, g]),
                friction_force=float(result.friction_force[j, b, g]),
                contact_angle=float(result.contact_angle[j, b, g]),
                max_pressure=float(result.max_pressure[j, b, g]),
                semi_axis_x=float(result.semi_axis_x[j, b, g]),
                semi_axis_y=float(result.semi_axis_y[j, b, g]),
                film_thickness=float(result.film_thickness[j, b, g]),
                tallian_parameter=float(result.tallian[j, b, g]),
                lubricant_share=float(result.lubricant_share[j, b, g]),
                dry_share=float(result.dry_share[j, b, g]),
                slip_speed=float(result.slip[j, b, g]),
            )
        )
    return states


def plot_result(result: SimulationResult, path: str | Path) -> Path:
    """PNG of screw speed (and command), motor torque and drag, and the power-balance error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    file = Path(path)
    sc = result.scenario
    t_ms = result.time * 1e3
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    ax = axes[0]
    ax.plot(t_ms, result.speed_command, "k--", lw=1, label="command")
    ax.plot(t_ms, result.screw_speed, lw=1, label="screw")
    ax.set_ylabel("speed [rad/s]")
    ax.legend(loc="best")
    ax = axes[1]
    ax.plot(t_ms, result.motor_torque * 1e3, lw=1, label="motor torque")
    ax.plot(t_ms, result.drag_torque * 1e3, lw=1, label="drag (motor - gravity)")
    drag = result.summary.get("drag_torque_Nm")
    if drag is not None and math.isfinite(drag):
        ax.axhline(drag * 1e3, color="r", lw=1, label=f"mean drag {drag * 1e3:.4g} mN m")
    ax.axvspan((sc.duration - sc.average_window) * 1e3, sc.duration * 1e3, color="0.9")
    ax.set_ylabel("torque [mN m]")
    ax.legend(loc="best")
    ax = axes[2]
    ax.plot(t_ms, result.power_balance_error * 1e3, lw=1, label="E - E0 - int(P_in - P_diss)")
    ax.plot(t_ms, result.input_energy * 1e3, lw=1, ls=":", label="input energy")
    ax.set_ylabel("energy [mJ]")
    ax.set_xlabel("time [ms]")
    ax.legend(loc="best")
    fig.suptitle(f"{sc.name}: dynamic model")
    fig.tight_layout()
    try:
        fig.savefig(file, dpi=110)
    except OSError as err:
        raise ResultsError(f"{file}: cannot write plot ({err.strerror})") from err
    finally:
        plt.close(fig)
    return file


def plot_contacts(result: SimulationResult, path: str | Path) -> Path | None:
    """PNG of every sphere's loaded contact on each side at the last contact sample (see
    :mod:`ballscrew_twin.plots.contact_states`); None when the run recorded no contact sample."""
    from .plots.contact_states import loaded_contacts, plot_sphere_states

    if len(result.contact_time) == 0:
        return None
    balls = len(result.ball_nut)
    grooves = result.in_contact.shape[-1]

    def last(values: np.ndarray) -> np.ndarray:
        return np.asarray(values[-1]).reshape(balls * grooves)

    states = loaded_contacts(
        np.repeat(np.arange(balls), grooves),
        np.repeat(result.ball_nut, grooves),
        np.tile(np.arange(grooves), balls),
        last(result.in_contact),
        last(result.normal_force),
        last(result.contact_angle),
        last(result.film_thickness),
        last(result.tallian),
    )
    sc = result.scenario
    title = (
        f"{sc.name}: dynamic model at t = {result.contact_time[-1] * 1e3:.4g} ms, "
        f"{result.screw_speed[-1]:.4g} rad/s, {sc.temperature - CELSIUS_ZERO:.4g} °C"
    )
    per_nut = int(np.count_nonzero(result.ball_nut == 0))
    try:
        return plot_sphere_states(states, per_nut, title, path)
    except BallscrewTwinError as err:
        raise ResultsError(str(err)) from err
