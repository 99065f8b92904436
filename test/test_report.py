"""``ballscrew-twin report paper --quick``: files written, CSV complete, numbers finite and SI."""

import contextlib
import csv
import io
import itertools
import math
from pathlib import Path

import pytest
from conftest import SavedFigures

from ballscrew_twin.cli import main
from ballscrew_twin.report.paper import COLUMNS, CSV_NAME, FILE_NAMES, Row, paper_grid, plot_paper

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """Run the quick report once; its output directory and what it printed."""
    out = tmp_path_factory.mktemp("paper_report")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["report", "paper", "--out", str(out), "--quick"]) == 0
    return out, printed.getvalue()


def read_rows(out: Path) -> tuple[list[str], list[dict[str, str]]]:
    with (out / CSV_NAME).open(encoding="utf-8", newline="") as stream:
        reader = csv.DictReader(stream)
        return list(reader.fieldnames or []), list(reader)


def test_writes_three_pngs_and_the_csv(report: tuple[Path, str]) -> None:
    out, printed = report
    for name in FILE_NAMES.values():
        data = (out / name).read_bytes()
        assert data.startswith(PNG_SIGNATURE), name
        assert len(data) > 20_000, name  # a drawn figure, not an empty canvas
    assert (out / CSV_NAME).is_file()
    assert "operating points converged" in printed and "wall time" in printed


def test_csv_has_the_expected_columns_and_rows(report: tuple[Path, str]) -> None:
    header, rows = read_rows(report[0])
    assert tuple(header) == COLUMNS
    for column in (
        "drag_torque_Nm",
        "eq51_drag_torque_Nm",
        "eq52_drag_torque_Nm",
        "screw_contact_angle_rad",
        "nut_max_pressure_Pa",
        "screw_friction_coefficient",
        "status",
    ):
        assert column in header
    grid = paper_grid(quick=True)
    per_curve = len(grid.preloads)
    expected = {
        "fig09": len(grid.temperatures) * per_curve,
        "fig10": len(grid.temperatures) * per_curve,
        "fig11": len(grid.speed_temperatures) * len(grid.speeds) * per_curve,
    }
    counts = {figure: sum(r["figure"] == figure for r in rows) for figure in expected}
    assert counts == expected


def test_values_are_finite_si_where_converged(report: tuple[Path, str]) -> None:
    _, rows = read_rows(report[0])
    numeric = [c for c in COLUMNS if c not in ("figure", "status") and "half_groove" not in c]
    converged = [r for r in rows if r["status"] == "ok"]
    assert len(converged) >= len(rows) // 2
    for row in converged:
        for column in numeric:
            assert math.isfinite(float(row[column])), (column, row)
        assert row["screw_half_groove"] in ("S1", "S2")
        assert row["nut_half_groove"] in ("N1", "N2")
        # SI: kelvin, rad/s, N m, rad, Pa (a unit slip would be off by orders of magnitude).
        assert float(row["temperature_K"]) == pytest.approx(float(row["temperature_C"]) + 273.15)
        assert float(row["screw_speed_rad_s"]) == pytest.approx(
            float(row["speed_rpm"]) * 2 * math.pi / 60
        )
        assert 0.0 < float(row["drag_torque_Nm"]) < 10.0
        assert 0.5 < float(row["screw_contact_angle_rad"]) < 1.1
        assert 1e8 < float(row["screw_max_pressure_Pa"]) < 1e10
    for row in rows:
        if row["status"] != "ok":
            assert math.isnan(float(row["drag_torque_Nm"]))  # recorded, never invented
            assert row["status"]


def test_eq51_and_eq52_columns_are_the_catalogue_formulas(report: tuple[Path, str]) -> None:
    _, rows = read_rows(report[0])
    at_3000 = next(r for r in rows if r["figure"] == "fig09" and float(r["preload_N"]) == 3000.0)
    # docs/model.md section 8: 97.0 and 38.3 N mm at 3000 N with mu_lit = 0.002.
    assert float(at_3000["eq51_drag_torque_Nm"]) == pytest.approx(0.0970, rel=2e-3)
    assert float(at_3000["eq52_drag_torque_Nm"]) == pytest.approx(0.0383, rel=2e-3)


def test_every_figure_carries_units(report: tuple[Path, str], saved_figures: SavedFigures) -> None:
    # Redraw the figures from the report's CSV and look at their axes (Fig. 10 (c)/(d) too).
    _, text_rows = read_rows(report[0])
    rows: list[Row] = [
        {
            k: (v if k in ("figure", "status") or "half_groove" in k else float(v))
            for k, v in r.items()
        }
        for r in text_rows
    ]
    paths = plot_paper(rows, report[0] / "again")
    assert saved_figures.paths() == [str(p) for p in paths]
    assert saved_figures.missing_units() == []
    fig10 = saved_figures.saved[1][0]
    labels = {ax.get_title()[:3]: ax.get_ylabel() for ax in fig10.axes}
    assert labels["(c)"].endswith("[N]") and labels["(d)"].endswith("[N]")


# ------------------------------------------------------------------ report gaps (issue 15)


def test_gap_variants_replace_laws_only_inside_their_block() -> None:
    """A variant changes the law the reference backend calls, inside the block only; the
    compiled backend (the shipped model) is not affected."""
    import numpy as np

    from ballscrew_twin.models.steady import SteadyStateModel
    from ballscrew_twin.params import load_config
    from ballscrew_twin.physics import rolling
    from ballscrew_twin.report import gaps

    config = load_config()
    shipped_law = rolling.hysteresis_moment
    args = (np.array([10.0, 170.0]), 1.5875e-3, np.array([30.0, 30.0]), 0.01, 0.0175)
    op = gaps.operating_point(20.0, 100.0, 1500.0)
    compiled = SteadyStateModel(config, mode="symmetric").solve(op).output.drag_torque
    with gaps.variant_laws("mer_mm+no_fr", config):
        assert rolling.hysteresis_moment is not shipped_law
        np.testing.assert_allclose(
            rolling.hysteresis_moment(*args), gaps.MER_MM_READING * shipped_law(*args), rtol=1e-12
        )
        assert not np.any(rolling.rolling_resistance_force(np.ones(3), 1, 1, 1, 1, 1.0))
        inside = SteadyStateModel(config, mode="symmetric").solve(op).output.drag_torque
    assert rolling.hysteresis_moment is shipped_law
    assert inside == compiled
    with (
        pytest.raises(ValueError, match="unknown variant 'nope'"),
        gaps.variant_laws("shipped+nope", config),
    ):
        pass


def test_spin_sliding_variants_set_the_spin_sliding_speed_inside_their_block() -> None:
    """The spin-sliding variants (D11) replace c in v_spin = c a |omega_spin| of the reference
    laws inside the block only; MP grows with c (the friction force rises with the sliding
    speed), and the compiled (shipped) model is untouched."""
    from ballscrew_twin.models import contact_forces
    from ballscrew_twin.models.steady import SteadyStateModel
    from ballscrew_twin.params import load_config
    from ballscrew_twin.report import gaps

    config = load_config()
    shipped = contact_forces.SPIN_SLIDING_FACTOR
    assert shipped == pytest.approx(4.0 / (3.0 * math.pi))
    op = gaps.operating_point(20.0, 100.0, 1500.0)
    compiled = SteadyStateModel(config, mode="symmetric").solve(op).output.drag_torque
    spin = {}
    for name in ("spin_sliding_half", "shipped", "spin_sliding_pressure", "spin_sliding_edge"):
        with gaps.variant_laws(name, config):
            factor = contact_forces.SPIN_SLIDING_FACTOR
            assert factor == gaps.SPIN_SLIDING_FACTORS.get(name, shipped)
            inside = SteadyStateModel(config, mode="symmetric").solve(op).output.drag_torque
            assert inside == compiled
        (solution,) = gaps.solve_curve(config, name, 20.0, 100.0, (1500.0,))
        assert not isinstance(solution, Exception)
        spin[factor] = solution.output.breakdown.spin
        assert shipped == contact_forces.SPIN_SLIDING_FACTOR
    moments = [spin[c] for c in sorted(spin)]
    assert all(b > a for a, b in itertools.pairwise(moments)), spin


def test_gap_shipped_variant_is_the_shipped_model() -> None:
    """The studies' baseline (reference backend, no variant) is the compiled model's drag."""
    from ballscrew_twin.models.steady import SteadyStateModel
    from ballscrew_twin.params import load_config
    from ballscrew_twin.report import gaps

    config = load_config()
    (solution,) = gaps.solve_curve(config, "shipped", 60.0, 100.0, (3000.0,))
    assert not isinstance(solution, Exception)
    op = gaps.operating_point(60.0, 100.0, 3000.0)
    compiled = SteadyStateModel(config, mode="symmetric").solve(op).output.drag_torque
    assert solution.output.drag_torque == pytest.approx(compiled, rel=1e-8)


def test_friction_moment_bound_of_synthetic_breakdowns() -> None:
    """Shape and error floor: MC + MP growing as the preload give a straight line (floor 0);
    MC + MP making half the drag at 500 N and growing as F^(4/3) give shape 1 + (6^(1/3)-1)/2."""
    from ballscrew_twin.report.gaps import friction_moment_bound

    def parts(moments_high: float) -> dict[str, tuple[float, float, float]]:
        return {
            "curvature": (0.0, 0.0, math.nan),
            "spin": (1.0, moments_high, math.nan),
            "total": (2.0, 6.0 + moments_high, math.nan),
        }

    assert friction_moment_bound(parts(6.0)) == pytest.approx((1.0, 0.0))
    shape, floor = friction_moment_bound(parts(6.0 ** (4.0 / 3.0)))
    assert shape == pytest.approx(1.0 + (6.0 ** (1.0 / 3.0) - 1.0) / 2.0)
    assert floor == pytest.approx((shape - 1.0) / (shape + 1.0))


def test_report_gaps_film_study_writes_json(tmp_path: Path) -> None:
    """``report gaps --study film``: alpha_pv of each variant at -20/20/60 C (100 and 1000 rpm),
    the shipped one the parameter file's, the derived ones falling with temperature."""
    import json

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["report", "gaps", "--study", "film", "--out", str(tmp_path)]) == 0
    rows = json.loads((tmp_path / "gaps.json").read_text(encoding="utf-8"))["film"]
    assert len(rows) == 18 and "wall time" in printed.getvalue()
    alpha = {(r["temperature_C"], r["variant"]): r["alpha_pv_per_GPa"] for r in rows}
    for celsius in (-20.0, 20.0, 60.0):
        assert alpha[(celsius, "shipped")] == pytest.approx(23.805)
    for variant in ("film_alpha_initial", "film_alpha_asymptotic"):
        assert alpha[(-20.0, variant)] > alpha[(20.0, variant)] > alpha[(60.0, variant)]
    for row in rows:
        assert all(math.isfinite(row[k]) for k in ("screw_film_nm", "screw_tallian", "drag_Nmm"))
