"""``ballscrew-twin drag``: drag torque and contact states at one operating point.

Speeds are given in rpm and temperatures in degrees Celsius on the command line, as the paper
and the catalogues state them, and converted to rad/s and K here, at the edge; the output is SI
(``--json``) or a table. The point is evaluated inside the validity envelope (clamped, with a
note, outside it). :func:`command_line_model` is also the model factory of ``sweep``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from ..errors import BallscrewTwinError
from ..models.base import OperatingPoint, SteadyStateModel, TwinOutput
from ..models.registry import (
    ModelName,
    accepted_names,
    as_evaluating,
    build,
    model_name,
    with_steady_mode,
)
from ..models.validity import ValidatedModel, ValidityEnvelope, kelvin_from_command_line
from ..params import TwinConfig, load_config
from ..physics.geometry import HALF_GROOVE_NAMES
from ..plots.contact_states import NUT_NAMES, from_contact_states, plot_sphere_states
from ..units import CELSIUS_ZERO, RPM

#: Models ``drag`` and ``sweep`` evaluate (``--model``): those with a steady ``evaluate``, by
#: their registry names or the older catalog (Eq. 51), zhou (Eq. 52) and steady.
MODEL_CHOICES = tuple(name for name in accepted_names("cli") if name != ModelName.DYNAMIC)
#: Models that resolve every sphere's contacts (``--plot``).
_PER_SPHERE = (ModelName.STEADY, ModelName.STEADY_SYMMETRIC, ModelName.STEADY_FULL)


def command_line_model(model: str, mode: str, config: TwinConfig) -> SteadyStateModel:
    """The model of ``--model`` (:data:`MODEL_CHOICES`) and ``--mode`` (spheres of the steady
    model: auto, symmetric or full; the other models ignore it), built by the registry."""
    name = with_steady_mode(model_name(model, "cli"), mode)
    return as_evaluating(build(name, config))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``drag``."""
    parser.add_argument("--preload", type=float, required=True, help="preload force [N]")
    parser.add_argument("--speed", type=float, required=True, help="screw speed [rpm]")
    parser.add_argument("--temperature", type=float, required=True, help="temperature [deg C]")
    parser.add_argument("--axial-load", type=float, default=0.0, help="external load [N]")
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--model", default="steady", choices=MODEL_CHOICES)
    parser.add_argument("--mode", default="auto", choices=("auto", "symmetric", "full"))
    parser.add_argument("--json", action="store_true", help="machine-readable output (SI)")
    parser.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="write the contact states per sphere of each nut here (steady model)",
    )


def output_to_dict(out: TwinOutput) -> dict[str, Any]:
    """JSON-ready dictionary of a model output, SI units, loaded contacts only."""
    op = out.operating_point
    result: dict[str, Any] = {
        "operating_point": {
            "screw_speed_rad_s": op.screw_speed,
            "temperature_K": op.temperature,
            "preload_N": op.preload,
            "axial_load_N": op.axial_load,
        },
        "fidelity": out.fidelity,
        "drag_torque_Nm": out.drag_torque,
        "nut_torque_Nm": {"master": out.nut_torque[0], "slave": out.nut_torque[1]},
        "breakdown_Nm": {
            "lubricant_shear": out.breakdown.lubricant_shear,
            "dry_contact": out.breakdown.dry_contact,
            "rolling_resistance": out.breakdown.rolling_resistance,
            "hysteresis": out.breakdown.hysteresis,
            "curvature": out.breakdown.curvature,
            "spin": out.breakdown.spin,
        },
        "notes": list(out.notes),
        "contacts": [],
    }
    cs = out.contacts
    if cs is not None:
        seen: set[tuple[int, int]] = set()
        for i in range(len(cs.sphere)):
            key = (int(cs.nut[i]), int(cs.half_groove[i]))
            if not cs.in_contact[i] or key in seen:
                continue
            seen.add(key)
            result["contacts"].append(
                {
                    "nut": NUT_NAMES[key[0]],
                    "half_groove": HALF_GROOVE_NAMES[key[1]],
                    "sphere": int(cs.sphere[i]),
                    "normal_force_N": float(cs.normal_force[i]),
                    "contact_angle_rad": float(cs.contact_angle[i]),
                    "semi_axis_x_m": float(cs.semi_axis_x[i]),
                    "semi_axis_y_m": float(cs.semi_axis_y[i]),
                    "max_pressure_Pa": float(cs.max_pressure[i]),
                    "stiffness_N_m1_5": float(cs.stiffness[i]),
                    "film_thickness_m": float(cs.film_thickness[i]),
                    "tallian_parameter": float(cs.tallian_parameter[i]),
                    "load_share": float(cs.load_share[i]),
                    "shear_stress_Pa": float(cs.shear_stress[i]),
                    "friction_force_N": float(cs.friction_force[i]),
                    "slip_speed_m_s": float(cs.slip_speed[i]),
                }
            )
    return result


def format_output(data: dict[str, Any]) -> str:
    """Human-readable report of :func:`output_to_dict`'s result."""
    op = data["operating_point"]
    lines = [
        f"model {data['fidelity']}: speed {op['screw_speed_rad_s']:.4g} rad/s "
        f"({op['screw_speed_rad_s'] / RPM:.4g} rpm), T {op['temperature_K']:.2f} K "
        f"({op['temperature_K'] - CELSIUS_ZERO:.2f} C), preload {op['preload_N']:.4g} N",
        f"drag torque      {data['drag_torque_Nm']:.6g} N m",
        f"  master nut     {data['nut_torque_Nm']['master']:.6g} N m",
        f"  slave nut      {data['nut_torque_Nm']['slave']:.6g} N m",
    ]
    for name, value in data["breakdown_Nm"].items():
        lines.append(f"  {name:<16} {value:.6g} N m")
    if data["contacts"]:
        header = (
            f"{'nut':<7}{'hg':<4}{'Fn[N]':>9}{'alpha[deg]':>11}{'ax[um]':>8}{'ay[um]':>8}"
            f"{'pmax[GPa]':>10}{'K[N/m^1.5]':>12}{'h[nm]':>8}{'Lambda':>8}{'f':>7}"
            f"{'tau[MPa]':>9}{'Ft[N]':>9}"
        )
        lines += ["", header]
        for c in data["contacts"]:
            lines.append(
                f"{c['nut']:<7}{c['half_groove']:<4}{c['normal_force_N']:9.3f}"
                f"{math.degrees(c['contact_angle_rad']):11.3f}{c['semi_axis_x_m'] * 1e6:8.2f}"
                f"{c['semi_axis_y_m'] * 1e6:8.1f}{c['max_pressure_Pa'] * 1e-9:10.3f}"
                f"{c['stiffness_N_m1_5']:12.4e}{c['film_thickness_m'] * 1e9:8.2f}"
                f"{c['tallian_parameter']:8.3f}{c['load_share']:7.3f}"
                f"{c['shear_stress_Pa'] * 1e-6:9.3f}{c['friction_force_N']:9.4f}"
            )
    lines += [f"note: {n}" for n in data["notes"]]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """``drag``: one operating point through the chosen model, inside the validity envelope.

    Outside the envelope (docs/model.md section 13) the point is clamped and every clamp is a
    note of the output, also printed on stderr; a temperature that reads as kelvin typed as
    degrees Celsius is refused with that hint.
    """
    if args.plot is not None and model_name(args.model, "cli") not in _PER_SPHERE:
        raise BallscrewTwinError(
            f"--plot: the {args.model} model does not resolve contacts; use --model steady"
        )
    config = load_config(args.config)
    envelope = ValidityEnvelope.for_config(config)
    op = OperatingPoint(
        screw_speed=args.speed * RPM,
        temperature=kelvin_from_command_line(args.temperature, "--temperature", envelope),
        preload=args.preload,
        axial_load=args.axial_load,
    )
    model = ValidatedModel(command_line_model(args.model, args.mode, config), envelope)
    out = model.evaluate(op)
    for note in out.notes:
        if note.startswith("validity:"):
            print(f"ballscrew-twin drag: {note}", file=sys.stderr)
    data = output_to_dict(out)
    print(json.dumps(data, indent=2) if args.json else format_output(data))
    if args.plot is not None and out.contacts is not None:
        title = (
            f"{out.fidelity}: {args.speed:g} rpm, {args.temperature:g} °C, "
            f"preload {args.preload:g} N, axial load {args.axial_load:g} N"
        )
        path = plot_sphere_states(
            from_contact_states(out.contacts), config.screw.balls_per_nut, title, args.plot
        )
        print(f"wrote {path}", file=sys.stderr if args.json else sys.stdout)
    return 0
