"""The plots of drift-and-recover episodes and of a suite's tracks draw what their data holds (hand-made data)."""

import numpy as np

from conftest import drawn_pixels, image_of, legend_of


def _episodes():
    """40 frames at 10 frames/s: drift out at 5-9, recover at 10-14; drift out at 25-27, recover at 28-33; a drift
    out at 36-39 with no recovery after it (not an episode)."""
    labels = np.array(["drive"] * 40, dtype=object)
    labels[5:10], labels[10:15], labels[25:28], labels[28:34], labels[36:40] = (
        "drift-out", "recover", "drift-out", "recover", "drift-out")
    return labels


def test_the_recovery_plot_draws_each_episode_its_start_of_correction_and_every_model(tmp_path, saved_figures):
    from steerlab.evaluate.plots import episodes_of, plot_recovery

    t = np.arange(40) / 10.0
    target = np.radians(np.linspace(-5.0, 5.0, 40))
    preds = {"a": target * 0.5, "b": -target}
    labels = _episodes()
    assert episodes_of(labels) == [(5, 10, 15), (25, 28, 34)]
    assert plot_recovery(tmp_path / "recovery.png", t, target, preds, labels) == 2
    fig = saved_figures[str(tmp_path / "recovery.png")]
    img = image_of(tmp_path / "recovery.png")
    assert img.shape[:2] == (320, 920)  # 4.6 x 2 by 3.2 inches at 100 dpi: one row of two panels
    assert len(fig.axes) == 2 and legend_of(fig.axes[0]) == ["driver", "a", "b"]
    for ax, (a, b, c) in zip(fig.axes, [(5, 10, 15), (25, 28, 34)]):
        w = slice(max(a - 20, 0), min(c + 20, 40))  # 2 s either side at 10 frames/s
        driver, correction, circle, line_a, line_b = ax.get_lines()
        np.testing.assert_allclose(driver.get_xdata(), t[w])
        np.testing.assert_allclose(driver.get_ydata(), np.degrees(target[w]))
        np.testing.assert_allclose(correction.get_xdata(), t[b:c])  # the correction, dashed
        assert correction.get_linestyle() == "--"
        np.testing.assert_allclose(circle.get_xydata(), [[t[b], np.degrees(target[b])]])
        np.testing.assert_allclose(line_a.get_ydata(), np.degrees(preds["a"][w]))
        np.testing.assert_allclose(line_b.get_ydata(), np.degrees(preds["b"][w]))
        [shade] = ax.patches  # the drift out, shaded from its first frame to the first of the correction
        x0, x1 = shade.get_x(), shade.get_x() + shade.get_width()
        np.testing.assert_allclose([x0, x1], [t[a], t[b]])
        for line in (driver, line_a, line_b):
            assert drawn_pixels(img, ax, line.get_color()) > 100


def test_no_episode_draws_no_recovery_plot(tmp_path):
    from steerlab.evaluate.plots import plot_recovery

    labels = np.array(["drive"] * 10 + ["drift-out"] * 5, dtype=object)  # a drift out never recovered
    assert plot_recovery(tmp_path / "r.png", np.arange(15) / 10.0, np.zeros(15), {"a": np.zeros(15)}, labels) == 0
    assert not (tmp_path / "r.png").exists()


def test_a_suite_track_plot_draws_the_lane_the_expert_and_each_checkpoint_with_its_off_track_events(tmp_path,
                                                                                                      saved_figures):
    from types import SimpleNamespace

    from steerlab.sim.core.driving import Trajectory
    from steerlab.sim.track.plots import plot_tracks
    from steerlab.sim.track.track import Track

    track = Track(9451, 0.9, "centre")
    n = 30

    def drive(folder, shift, hits):
        """A drive along the centre line `shift` m to the left, put back at the ticks `hits`."""
        left = track.offset(shift)
        zeros, hit = np.zeros(n), np.zeros(n)
        hit[hits] = 1
        t = Trajectory(np.arange(n) / 20.0, left[0][:n], left[1][:n], zeros, zeros, zeros, np.full(n, 1.5), zeros,
                       hit)
        (tmp_path / folder / "centre-9451").mkdir(parents=True)
        t.write(tmp_path / folder / "centre-9451" / "trajectory.csv")

    drive("expert", 0.0, [])
    drive("m", 0.2, [10, 20])
    row = SimpleNamespace(style="centre", seed=9451, label="m", clean_laps=0, laps=1)
    plot_tracks(tmp_path, [row], 0.9, "expert")
    png = tmp_path / "tracks" / "centre-9451.png"
    ax, speed = saved_figures[str(png)].axes
    assert legend_of(ax) == ["start line", "expert (0 off track)", "m: 0/1 clean laps (2 off track)"]
    edges = ax.get_lines()[:3]  # the lane's edges and, on a centre-line track, its painted line (solid)
    for line, d in zip(edges, (-0.45, 0.45, 0.0)):
        ex, ey = track.offset(d)
        np.testing.assert_allclose(line.get_xdata()[:-1], ex)
        np.testing.assert_allclose(line.get_ydata()[:-1], ey)
    assert edges[2].get_linestyle() == "-"
    lines = {line.get_label(): line for line in ax.get_lines()}
    m_line = lines["m: 0/1 clean laps (2 off track)"]
    m_x = m_line.get_xdata()
    assert np.isnan(m_x[[10, 20]]).all() and np.isfinite(np.delete(m_x, [10, 20])).all()  # no line across a put-back
    marks = [line for line in ax.get_lines() if line.get_marker() == "x"]
    np.testing.assert_allclose(marks[1].get_xdata(), track.offset(0.2)[0][[9, 19]], atol=1e-4)  # before each
    assert not len(marks[0].get_xdata())  # the expert never left
    assert [line.get_label() for line in speed.get_lines()] == ["expert", "m: 0/1 clean laps"]
    img = image_of(png)
    assert drawn_pixels(img, ax, m_line.get_color()) > 50
