"""Contact states per sphere around each nut: normal force, contact angle, film thickness and
Tallian parameter Lambda of the loaded contact on the screw side and on the nut side.

Each sphere touches the screw on one half groove (S1 or S2) and the nut on one (N1 or N2); the
loaded one of each side is the one with the larger normal force (as in the report's Fig. 10). A
sphere with no contact on a side shows a gap there. When a nut is solved with a single sphere
that stands for all of them (the steady model's symmetric mode), its state is drawn as a line
across every sphere position of the nut.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..models.base import ContactStates
from .save import save_png

FloatArray = NDArray[np.float64]
NUT_NAMES = ("master", "slave")
SIDE_NAMES = ("screw", "nut")
#: Drawn quantities: (attribute of SphereStates, factor to the plotted unit, axis label).
PANELS = (
    ("normal_force", 1.0, "normal force F_n [N]"),
    ("contact_angle", 180.0 / math.pi, "contact angle [deg]"),
    ("film_thickness", 1e9, "film thickness h [nm]"),
    ("tallian", 1.0, "Tallian parameter Λ [-]"),
)


@dataclass(frozen=True)
class SphereStates:
    """The loaded contact of every sphere on each side (column 0 screw, 1 nut), SI units.

    Attributes:
        nut: nut of each sphere (0 master, 1 slave), shape (S,).
        index: position of the sphere in its nut's loaded helix, 0 first [-], shape (S,).
        normal_force: F_n [N], shape (S, 2); NaN where the sphere does not touch that side.
        contact_angle: [rad], shape (S, 2).
        film_thickness: central film h [m], shape (S, 2).
        tallian: Lambda [-], shape (S, 2).
    """

    nut: NDArray[np.int64]
    index: NDArray[np.int64]
    normal_force: FloatArray
    contact_angle: FloatArray
    film_thickness: FloatArray
    tallian: FloatArray


def loaded_contacts(
    sphere: NDArray[np.int64],
    nut: NDArray[np.int64],
    half_groove: NDArray[np.int64],
    in_contact: NDArray[np.bool_],
    normal_force: FloatArray,
    contact_angle: FloatArray,
    film_thickness: FloatArray,
    tallian: FloatArray,
) -> SphereStates:
    """Per sphere and side, the loaded half groove's state (rows of one contact each, as in
    :class:`~ballscrew_twin.models.base.ContactStates`; half grooves 0..3 = S1, S2, N1, N2).

    Spheres are numbered in each nut by increasing ``sphere`` id.
    """
    ids = np.unique(sphere)
    count = len(ids)
    quantities = (normal_force, contact_angle, film_thickness, tallian)
    out = [np.full((count, 2), np.nan) for _ in quantities]
    nut_of = np.zeros(count, dtype=np.int64)
    for k, sphere_id in enumerate(ids):
        rows = np.flatnonzero(sphere == sphere_id)
        nut_of[k] = nut[rows[0]]
        for side in (0, 1):
            on_side = rows[((half_groove[rows] >= 2) == bool(side)) & in_contact[rows]]
            if len(on_side) == 0:
                continue
            i = on_side[np.argmax(normal_force[on_side])]
            for target, values in zip(out, quantities, strict=True):
                target[k, side] = values[i]
    index = np.zeros(count, dtype=np.int64)
    for n in (0, 1):
        members = np.flatnonzero(nut_of == n)
        index[members] = np.arange(len(members))
    return SphereStates(nut_of, index, *out)


def from_contact_states(contacts: ContactStates) -> SphereStates:
    """:func:`loaded_contacts` of a model output's contact states."""
    return loaded_contacts(
        contacts.sphere,
        contacts.nut,
        contacts.half_groove,
        contacts.in_contact,
        contacts.normal_force,
        contacts.contact_angle,
        contacts.film_thickness,
        contacts.tallian_parameter,
    )


def plot_sphere_states(
    states: SphereStates, spheres_per_nut: int, title: str, path: str | Path
) -> Path:
    """PNG of the four quantities against the sphere's place in its nut, both nuts and sides.

    Args:
        states: what to draw.
        spheres_per_nut: loaded spheres of a nut (Z_eff); a nut drawn from one sphere stands
            for all of them and is drawn across 0 .. Z_eff - 1.
        title: figure title (operating point, model).
        path: PNG file to write (its folder is created).
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.ticker import MaxNLocator

    fig = Figure(figsize=(9, 10), layout="constrained")
    axes = fig.subplots(len(PANELS), 1, sharex=True)
    span = np.array([0, max(spheres_per_nut - 1, 0)])
    for n in range(len(NUT_NAMES)):
        members = np.flatnonzero(states.nut == n)
        if len(members) == 0:
            continue
        stands_for_all = len(members) == 1 and spheres_per_nut > 1
        for ax, (name, factor, _) in zip(axes, PANELS, strict=True):
            values: FloatArray = getattr(states, name)[members] * factor
            for side, style, marker in ((0, "-", "o"), (1, "--", "s")):
                if stands_for_all:
                    ax.plot(span, np.repeat(values[0, side], 2), style, color=f"C{n}", lw=1.5)
                else:
                    x = states.index[members]
                    ax.plot(x, values[:, side], style, marker=marker, ms=3, color=f"C{n}")
    for ax, (_, _, label) in zip(axes, PANELS, strict=True):
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("sphere in its nut, along the loaded helix [-]")
    axes[-1].xaxis.set_major_locator(MaxNLocator(integer=True))
    handles = [
        Line2D([], [], color=f"C{n}", label=f"{name} nut") for n, name in enumerate(NUT_NAMES)
    ]
    handles += [
        Line2D([], [], color="k", ls=style, marker=marker, label=f"{side} side")
        for side, style, marker in (("screw", "-", "o"), ("nut", "--", "s"))
    ]
    if any(np.count_nonzero(states.nut == n) == 1 for n in (0, 1)) and spheres_per_nut > 1:
        title += " (symmetric mode: one sphere stands for all of its nut)"
    axes[0].legend(handles=handles, loc="best", fontsize="small", ncols=2)
    fig.suptitle(title)
    return save_png(fig, path)
