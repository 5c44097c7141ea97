"""The campaign report's figures: units on every metric, plain tick labels, a strip below five runs a group, no
panel for a metric zero in every run. Checked on synthetic results (no campaign run needed)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from tiltload.master.app.campaign import figures as rp  # noqa: E402
from tiltload.master.app.campaign import report as campaign_report  # noqa: E402


def _rows(per_group: int, saturated: float = 0.0) -> list[dict]:
    rows = []
    for c in ("dlqr", "mixed"):
        for s in range(per_group):
            rows.append({"run_id": f"{c}{s}", "controller": c, "seed": s + 1, "completed": True, "diverged": False,
                         "diverged_at": None, "error": "", "load_mass": 0.05 * (s + 1),
                         "ISE(x)": 0.01 * 10 ** s, "ISE(y)": 0.2, "ISE(z)": 0.3, "max_tracking_error": 0.1 * (s + 1),
                         "IADU(f_R)": 6.0, "time_saturated": saturated, "zse_containment": float("nan")})
    return rows


def test_a_metric_zero_or_missing_in_every_run_has_no_panel():
    panels = dict(rp.distribution_panels(_rows(3), ["dlqr", "mixed"]))
    assert "time_saturated" not in panels  # zero everywhere: nothing saturated
    assert "zse_containment" not in panels  # NaN everywhere: no ZSE in this campaign
    assert "IADU(tau_R)" not in panels  # not kept
    assert {"ISE(x)", "ISE(y)", "ISE(z)", "max_tracking_error", "IADU(f_R)"} <= set(panels)
    assert "time_saturated" in dict(rp.distribution_panels(_rows(3, saturated=0.01), ["dlqr", "mixed"]))


def test_a_group_of_three_runs_is_drawn_as_points_and_one_of_six_as_a_box():
    assert rp.group_kind([1.0, 2.0, 3.0]) == "strip" and rp.group_kind([1.0] * 4) == "strip"
    assert rp.group_kind([1.0] * 5) == "box"
    fig, ax = plt.subplots()
    kinds = rp.draw_distribution(ax, "max_tracking_error", [[0.1, 0.2, 0.3], [0.1 * k for k in range(1, 7)]],
                                 ["dlqr", "mixed"])
    assert kinds == ["strip", "box"]
    from matplotlib.collections import PathCollection

    (points,) = [c for c in ax.collections if isinstance(c, PathCollection)]  # one scatter, of the three; six: a box
    assert len(points.get_offsets()) == 3
    plt.close(fig)


def test_log_ticks_are_plain_numbers_and_every_axis_has_a_unit():
    fig, ax = plt.subplots()
    rp.draw_distribution(ax, "ISE(x)", [[0.01, 0.1, 1.0], [0.145, 2.0]], ["dlqr", "mixed"])
    assert ax.get_yscale() == "log"
    assert ax.yaxis.get_major_formatter()(0.145, 0) == "0.145"
    assert ax.yaxis.get_minor_formatter()(0.145, 0) == ""
    assert ax.get_ylabel() == "ISE(x) (m²·s)"
    plt.close(fig)
    for key, unit in (("ISE(psi)", "rad²·s"), ("IADU(tau_L)", "N m"), ("IADU(f_R)", "N"), ("max_tracking_error", "m")):
        assert rp.metric_unit(key) == unit
    for key in rp.DISTRIBUTIONS:
        assert rp.metric_unit(key)


def test_a_varied_parameter_s_unit_comes_from_the_model_parameter_it_sets():
    spec = {"vary": {"parameters": [{"name": "load_mass", "targets": ["plant.m_L"]},
                                    {"name": "rod_length", "targets": ["plant.l", "sensors.l"]}]}}
    assert rp.parameter_unit("load_mass", spec) == "kg" and rp.parameter_unit("rod_length", spec) == "m"
    assert rp.axis_label("gain", "") == "gain"


def test_a_report_whose_metrics_are_all_zero_has_no_distributions_figure(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = [{**r, **{k: 0.0 for k in ("ISE(x)", "ISE(y)", "ISE(z)", "max_tracking_error", "IADU(f_R)")}}
            for r in _rows(2)]
    pq.write_table(pa.Table.from_pylist(rows), tmp_path / "results.parquet")
    text = campaign_report.report(tmp_path / "results.parquet").read_text()
    assert not (tmp_path / "distributions.png").exists() and "distributions.png" not in text


def test_each_run_is_a_point_coloured_by_its_varied_value():
    """With colours, every run is a point over its box, its colour its varied value (the figure's colour bar names it)."""
    rows = [{"controller": c, "completed": True, "diverged": False, "max_tracking_error": 0.1 * k, "mass": 0.05 * k}
            for c in ("dlqr", "mixed") for k in range(1, 8)]
    data = dict(rp.distribution_panels(rows, ["dlqr", "mixed"], keys=("max_tracking_error",)))["max_tracking_error"]
    colours = rp.panel_colours(rows, ["dlqr", "mixed"], "max_tracking_error", "mass")
    fig, ax = plt.subplots()
    assert rp.draw_distribution(ax, "max_tracking_error", data, ["dlqr", "mixed"], colours) == ["box", "box"]
    drawn = [c for c in ax.collections if c.get_array() is not None]
    assert len(drawn) == 2
    for points, expected_y, expected_colour in zip(drawn, data, colours):
        assert [y for _, y in points.get_offsets()] == expected_y and list(points.get_array()) == expected_colour
    plt.close(fig)
