"""rgb_array frames (planetnav_env/envs/render.py): shape, content that follows the state, labelled axes, the
one-way dependency render <- env, and the command line that regenerates docs/render_frame.png."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.attitude import quaternion as qt
from planetnav_env.envs.render import FRAME_SIZE_PX, FrameData, figure_for, main, render_frame

RENDER_PY = Path(__file__).resolve().parents[2] / "planetnav_env" / "envs" / "render.py"
SHORT = {"episode_steps": 40}


def _env(env_id: str = "planetnav/Cruise-Target-v0", **kw):
    return gym.make(env_id, render_mode="rgb_array", **{**SHORT, **kw}).unwrapped


def _data_after(env, actions) -> FrameData:
    env.reset(seed=0)
    for a in actions:
        env.step(a)
    return env._frame_data()


def test_frame_shape_dtype_and_no_frame_without_render_mode():
    env = _env()
    env.reset(seed=0)
    frame = env.render()
    w, h = FRAME_SIZE_PX
    assert frame.shape == (h, w, 3) and frame.dtype == np.uint8
    # Not blank: a real drawing has many distinct colours.
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 50
    assert gym.make("planetnav/Cruise-Target-v0", **SHORT).unwrapped.render() is None


def test_frame_data_is_heliocentric_and_consistent_with_the_env():
    env = _env()
    data = _data_after(env, [0, 0, 0])
    central = env.body_positions()["central"]
    np.testing.assert_allclose(data.spacecraft_km, env.truth["x"][:3] + central)
    assert data.step == 3 and data.time_s == pytest.approx(3 * env.config.step_s)
    assert data.history_km.shape == (4, 2)
    assert data.target == "venus" and data.planet_names == env.planets
    assert data.position_cov_km2.shape == (3, 3)
    # The estimate is as far from the truth as the env reports.
    assert np.linalg.norm(data.estimate_km - data.spacecraft_km) == pytest.approx(data.history_km[-1, 0])


def test_frame_changes_when_the_target_changes():
    env = _env()
    data = _data_after(env, [0] * 5)
    a = render_frame(data)
    b = render_frame(dataclasses.replace(data, target="mars"))
    assert a.shape == b.shape
    assert np.count_nonzero(np.any(a != b, axis=-1)) > 200
    # And through the env: a few steps toward another planet redraw the camera and the curves.
    env.step(1)
    later = env.render()
    assert np.count_nonzero(np.any(later != a, axis=-1)) > 200


def test_target_is_named_in_view_and_pointed_at_when_outside():
    env = _env("planetnav/MarsApproach-Tasking-v0", episode_steps=60)
    data = _data_after(env, [0] * 20)  # on Mars
    fig = figure_for(data)
    texts = [t.get_text() for ax in fig.axes for t in ax.texts if t.get_visible()]
    assert any(t.startswith("Mars (") for t in texts), texts
    assert any("target: Mars" in t for t in texts)
    # Turn the spacecraft 90 deg: the target leaves the panel and an arrow names it with its angle.
    turned = qt.multiply(data.attitude_q, qt.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi / 2))
    fig = figure_for(dataclasses.replace(data, attitude_q=turned))
    texts = [t.get_text() for ax in fig.axes for t in ax.texts if t.get_visible()]
    assert any(t.startswith("Mars:") and t.endswith("° off") for t in texts), texts
    assert not any(t.startswith("Mars (") for t in texts)


def test_axes_have_labels_units_log_scale_and_legends():
    env = _env()
    fig = figure_for(_data_after(env, [0] * 3))
    by_title = {ax.get_title(): ax for ax in fig.axes}
    err = by_title["Navigation error"]
    assert err.get_yscale() == "log"
    assert "[km]" in err.get_ylabel() and "[h]" in err.get_xlabel()
    legend = [t.get_text() for t in err.get_legend().get_texts()]
    assert any("error" in t for t in legend) and any("1-sigma" in t for t in legend)
    orbit = next(ax for t, ax in by_title.items() if t.startswith("Orbit"))
    assert "[AU]" in orbit.get_xlabel() and "[AU]" in orbit.get_ylabel()
    camera = next(ax for ax in fig.axes if "camera x" in ax.get_xlabel())
    assert "[deg]" in camera.get_xlabel() and "[deg]" in camera.get_ylabel()
    # The zoom inset states its scale; the orbit's legend names truth, estimate and the 1-sigma ellipse.
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any(t.startswith("zoom: ±") and t.endswith(" km about spacecraft") for t in texts), texts
    legend = [t.get_text() for t in orbit.get_legend().get_texts()]
    assert legend == ["spacecraft (truth)", "estimate (zoom)", "filter 1-sigma (zoom)"]


def test_blitted_frame_equals_a_fresh_full_draw():
    """The cached background must not leave stale pixels: the same data drawn after a frame with other
    axis limits (background redrawn) and twice in a row (background reused) give the same array."""
    env = _env()
    late = _data_after(env, [0] * 30)
    early = _data_after(env, [0])
    first = render_frame(late)
    render_frame(early)  # other limits: redraws the background
    again = render_frame(late)
    assert np.array_equal(first, again)
    assert np.array_equal(again, render_frame(late))


@pytest.mark.parametrize("env_id", ["planetnav/Cruise-Target-v0", "planetnav/MarsApproach-Tasking-v0"])
def test_gymnasium_checker_passes_with_render(env_id):
    gym_check_env(_env(env_id), skip_render_check=False)


def test_render_module_does_not_import_the_env():
    """render.py takes a FrameData; importing planetnav_env.envs.env would make the circle env <-> render
    again."""
    tree = ast.parse(RENDER_PY.read_text())
    imported: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
            imported.update(f"{node.module}.{alias.name}" for alias in node.names)
    assert not any(
        name == "planetnav_env.envs.env" or name.startswith("planetnav_env.envs.env.") for name in imported
    )
    assert "planetnav_env.envs.render" not in imported  # and not itself
    assert "planetnav_env.sensors.camera" in imported  # the walk does see its imports


def test_command_line_writes_a_png(tmp_path):
    out = tmp_path / "frame.png"
    main(["--id", "planetnav/Cruise-Target-v0", "--steps", "5", "--out", str(out)])
    import matplotlib.image

    img = matplotlib.image.imread(out)
    w, h = FRAME_SIZE_PX
    assert img.shape[:2] == (h, w)
