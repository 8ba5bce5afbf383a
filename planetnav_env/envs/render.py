"""rgb_array frames: camera view, navigation error history and orbit view, drawn from a :class:`FrameData`.

A frame (``FRAME_SIZE_PX``, uint8 RGB) has three panels:

1. **Camera** (true attitude): the sky around the boresight, twice the sensor's field in each axis, with the
   field of view drawn as a dashed rectangle; catalogue stars, planet disks at their apparent size (at least
   ``MIN_DISK_DEG`` so a sub-pixel planet stays visible), X-ray pulsars as stars, the Sun when near. Every
   beacon is named; the target is ringed, and an arrow on the panel's edge points to it when it is outside.
2. **Error**: the true position error and the filter's 1-sigma (``sqrt(trace P_rr)``) over the episode so
   far, log axis in km, time in hours (the x axis spans the whole episode, so the curve grows left to right).
3. **Orbit**: heliocentric, projected on the J2000 ecliptic plane [AU]: the Sun, the beacon planets (with
   circles at their current distance), the spacecraft, lines of sight to the pulsars, and a zoom inset at
   true scale in km about the spacecraft (its half width is stated in its title): the filter's 1-sigma
   position ellipse (projected on the ecliptic plane) and the estimate. 1,000 km is far below a pixel at
   1 AU, hence the inset.

The environment builds the :class:`FrameData` from its public state (``PlanetNavEnv.render``); this module
never imports the environment, so the dependency points one way (render <- env). Matplotlib (Agg backend)
draws; one figure per beacon layout is kept, its axes and labels are cached as a background, and each frame
redraws only what moves (blitting), several times faster than drawing the whole figure.

Command line (regenerates ``docs/render_frame.png``)::

    python -m planetnav_env.envs.render --out docs/render_frame.png --id planetnav/Cruise-Target-v0 \
        --steps 300
"""

from __future__ import annotations

import argparse
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import matplotlib

matplotlib.use("Agg", force=False)  # no display in the step loop; a user's interactive backend is kept
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Ellipse, FancyArrowPatch, Rectangle

from planetnav_env.astro.bodies import AU_KM, ECLIPTIC_TO_EQUATORIAL
from planetnav_env.attitude import quaternion as qt
from planetnav_env.sensors.camera import CameraConfig

#: (width, height) of a frame [px]; multiples of 16 so video encoders take it without resizing.
FRAME_SIZE_PX = (1280, 480)
_DPI = 100
#: Smallest drawn planet disk radius [deg]: a planet at 1 AU is far below a pixel.
MIN_DISK_DEG = 0.35
#: The camera panel shows this many times the sensor's half field of view around the boresight.
VIEW_OVER_FOV = 2.0
#: Side of the orbit panel's zoom inset, as a fraction of the panel.
INSET_FRACTION = 0.38

PLANET_COLORS = {
    "mercury": "#b4aaa0",
    "venus": "#ffc850",
    "earth": "#5096ff",
    "moon": "#d2d2d2",
    "mars": "#e65a3c",
    "jupiter": "#dcb48c",
    "saturn": "#e6d296",
}
PULSAR_COLOR = "#e040fb"
ERROR_COLOR = "#d62728"
SIGMA_COLOR = "#1f77b4"


@dataclass(frozen=True)
class FrameData:
    """Everything one frame shows. Positions heliocentric [km] in ICRF (J2000 equatorial); directions ICRF
    unit vectors. Built by ``PlanetNavEnv.render`` from its public state.

    Attributes
    ----------
    title: headline (environment id or scenario).
    time_s: time since the episode's start [s].
    step: steps taken; ``episode_steps``: steps of a full episode; ``step_s``: step length [s].
    spacecraft_km: (3,) true position. ``estimate_km``: (3,) the filter's estimate.
    position_cov_km2: (3, 3) the filter's position covariance ``P_rr`` [km^2], ICRF.
    central: name of the body the dynamics are centred on (``"sun"`` or a planet).
    planet_names: the beacon planets (action order); ``planet_km``: (P, 3) their positions;
    ``planet_radii_km``: (P,) their radii.
    pulsar_names: the X-ray pulsars; ``pulsar_dirs``: (Q, 3) their directions.
    target: the current target's name or None; ``visibility``: why the last measurement was (not) taken
    (the env's ``info["visibility"]``); ``measured``: whether the last step measured.
    attitude_q: (4,) true attitude quaternion (planetnav convention,
        :mod:`planetnav_env.attitude.quaternion`).
    camera: the camera's intrinsics and mounting.
    star_dirs: (M, 3) the star catalogue.
    history_km: (N, 2) the true position error and the filter's 1-sigma [km] at steps 0..N-1.
    """

    title: str
    time_s: float
    step: int
    episode_steps: int
    step_s: float
    spacecraft_km: np.ndarray
    estimate_km: np.ndarray
    position_cov_km2: np.ndarray
    central: str
    planet_names: tuple[str, ...]
    planet_km: np.ndarray
    planet_radii_km: np.ndarray
    pulsar_names: tuple[str, ...]
    pulsar_dirs: np.ndarray
    target: str | None
    visibility: str
    measured: bool
    attitude_q: np.ndarray
    camera: CameraConfig
    star_dirs: np.ndarray
    history_km: np.ndarray


# ---------------------------------------------------------------------------------------------------------
# geometry (pure numpy)


def camera_angles_deg(data: FrameData, dirs_icrf: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angles [deg] of ICRF directions (N, 3) off the boresight along camera x and y, ``atan(x/z)`` and
    ``atan(y/z)``, and a mask of those in front of the camera (z > 0)."""
    v_body = qt.rotate_inertial_to_body(data.attitude_q, np.atleast_2d(dirs_icrf))
    v_cam = v_body @ data.camera.camera_to_body_matrix  # v_C = C^T v_B, row-wise
    front = v_cam[:, 2] > 0
    ax = np.degrees(np.arctan2(v_cam[:, 0], v_cam[:, 2]))
    ay = np.degrees(np.arctan2(v_cam[:, 1], v_cam[:, 2]))
    return ax, ay, front


def ecliptic_xy_au(vec_icrf_km: np.ndarray) -> np.ndarray:
    """(..., 2) ecliptic-plane x, y [AU] of ICRF vectors [km] (v_ecl = M^T v_eq)."""
    return (np.asarray(vec_icrf_km) @ ECLIPTIC_TO_EQUATORIAL)[..., :2] / AU_KM


def ellipse_ecliptic(cov_km2: np.ndarray) -> tuple[float, float, float]:
    """The 1-sigma ellipse of an ICRF position covariance projected on the ecliptic plane:
    semi-axes (major, minor) [km] and the major axis's angle from ecliptic x [deg]."""
    m = ECLIPTIC_TO_EQUATORIAL[:, :2]  # columns: ecliptic x, y in ICRF
    c2 = m.T @ np.asarray(cov_km2) @ m
    vals, vecs = np.linalg.eigh(0.5 * (c2 + c2.T))
    vals = np.clip(vals, 0.0, None)
    angle = float(np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1])))
    return float(np.sqrt(vals[1])), float(np.sqrt(vals[0])), angle


def _fmt_km(km: float) -> str:
    if not np.isfinite(km):
        return "n/a"
    if km >= 1e6:
        return f"{km / 1e6:.3g} million km"
    if km >= 100:
        return f"{km:,.0f} km"
    return f"{km:.3g} km"


# ---------------------------------------------------------------------------------------------------------
# the figure: built once per beacon layout, artists updated per frame


def _nice_ceil(x: float) -> float:
    """The smallest of (1, 1.25, 1.5, 1.75, 2, 2.5, 3, 4, 5, 6, 7.5) x 10^k at or above ``x`` (> 0): axis
    limits that change rarely, so the cached background is redrawn rarely."""
    k = np.floor(np.log10(x))
    for m in (1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.5, 10.0):
        if m * 10**k >= x * (1 - 1e-12):
            return float(m * 10**k)
    return float(10 ** (k + 1))


class _Canvas:
    """One figure for a beacon layout (planet and pulsar names), drawn by blitting.

    The axes, ticks, labels and legends (the text that costs most to draw) are drawn once per set of axis
    limits and kept as a background; each frame restores it and draws only the artists marked ``animated``
    (stars, disks, curves, markers, the moving texts). Axis limits are quantised (:func:`_nice_ceil`, whole
    decades) so the background is redrawn a handful of times per episode.
    """

    def __init__(self, planet_names: tuple[str, ...], pulsar_names: tuple[str, ...]):
        w, h = FRAME_SIZE_PX
        self.fig = Figure(figsize=(w / _DPI, h / _DPI), dpi=_DPI)
        FigureCanvasAgg(self.fig)
        self.dynamic: list[Any] = []  # drawn every frame, in this order
        self._background: Any = None
        self._background_key: tuple | None = None
        self.title = self._dyn(
            self.fig.text(0.5, 0.975, "", ha="center", va="top", fontsize=11, weight="bold")
        )
        # Panels placed by hand (no tight_layout per frame): camera | error | orbit.
        self.cam = self.fig.add_axes((0.045, 0.12, 0.27, 0.72))
        self.err = self.fig.add_axes((0.385, 0.12, 0.26, 0.72))
        self.orb = self.fig.add_axes((0.705, 0.12, 0.27, 0.72))
        self._build_camera(planet_names, pulsar_names)
        self._build_error()
        self._build_orbit(planet_names, pulsar_names)

    def _dyn(self, artist: Any) -> Any:
        """Mark ``artist`` as redrawn every frame (not part of the cached background)."""
        artist.set_animated(True)
        self.dynamic.append(artist)
        return artist

    # -- camera ------------------------------------------------------------------------------------------
    def _build_camera(self, planet_names: tuple[str, ...], pulsar_names: tuple[str, ...]) -> None:
        ax = self.cam
        ax.set_facecolor("black")
        ax.set_aspect("equal")
        ax.set_xlabel("camera x from boresight [deg]")
        ax.set_ylabel("camera y from boresight [deg]")
        self.fov = Rectangle((0, 0), 1, 1, fill=False, ec="#4dd0e1", ls="--", lw=1.2, zorder=3)
        ax.add_patch(self.fov)
        self.fov_label = ax.text(0, 0, "", color="#4dd0e1", fontsize=8, va="bottom", ha="left", zorder=5)
        ax.plot([0], [0], marker="+", ms=10, color="#888888", zorder=3)  # boresight
        self.cam_title = self._dyn(ax.text(0.5, 1.02, "", transform=ax.transAxes, ha="center", fontsize=10))
        self.stars = self._dyn(ax.scatter([], [], s=3, c="white", linewidths=0, alpha=0.8))
        self.sun_disk = self._dyn(Circle((0, 0), 1, color="#fff176", zorder=4, visible=False))
        ax.add_patch(self.sun_disk)
        self.sun_label = self._dyn(ax.text(0, 0, "Sun", color="#fff176", fontsize=9, visible=False, zorder=6))
        self.disks: list[Circle] = []
        for name in planet_names:
            disk = self._dyn(
                Circle((0, 0), 1, color=PLANET_COLORS.get(name, "#c8c8c8"), zorder=4, visible=False)
            )
            ax.add_patch(disk)
            self.disks.append(disk)
        (self.pulsar_marks,) = ax.plot([], [], ls="none", marker="*", ms=12, color=PULSAR_COLOR, zorder=5)
        self._dyn(self.pulsar_marks)
        self.ring = self._dyn(Circle((0, 0), 1, fill=False, ec="white", lw=1.5, zorder=5, visible=False))
        ax.add_patch(self.ring)
        self.cam_labels: dict[str, Any] = {}
        for name in (*planet_names, *pulsar_names):
            self.cam_labels[name] = self._dyn(ax.text(
                0, 0, "", color="white", fontsize=9, zorder=6, visible=False, clip_on=True,
                bbox={"boxstyle": "round,pad=0.15", "fc": "black", "ec": "none", "alpha": 0.6},
            ))  # fmt: skip
        self.pointer = FancyArrowPatch(
            (0, 0),
            (1, 1),
            arrowstyle="-|>",
            mutation_scale=18,
            color="#ffeb3b",
            lw=2,
            zorder=7,
            visible=False,
        )
        ax.add_patch(self._dyn(self.pointer))
        self.pointer_label = self._dyn(ax.text(
            0, 0, "", color="#ffeb3b", fontsize=9, weight="bold", zorder=7, visible=False, ha="center"
        ))  # fmt: skip
        self.cam_status = self._dyn(ax.text(
            0.02, 0.02, "", transform=ax.transAxes, color="white", fontsize=8.5, zorder=8,
            bbox={"boxstyle": "round,pad=0.2", "fc": "black", "ec": "#666666", "alpha": 0.7},
        ))  # fmt: skip

    def _update_camera(self, data: FrameData) -> tuple:
        ax = self.cam
        hx, hy = (float(np.degrees(a)) for a in data.camera.half_fov_rad)
        vx, vy = VIEW_OVER_FOV * hx, VIEW_OVER_FOV * hy
        _set_limits(ax, (-vx, vx), (vy, -vy))  # camera y points down the image, as on the sensor
        self.fov.set_bounds(-hx, -hy, 2 * hx, 2 * hy)
        self.fov_label.set_position((-hx, -hy - 0.04 * vy))
        self.fov_label.set_text(f"camera field {2 * hx:.1f}° x {2 * hy:.1f}°")
        target = _pretty(data.target) if data.target else "none"
        self.cam_title.set_text(f"Camera view - target: {target}")

        sx, sy, front = camera_angles_deg(data, data.star_dirs)
        keep = front & (np.abs(sx) <= vx) & (np.abs(sy) <= vy)
        self.stars.set_offsets(np.column_stack([sx[keep], sy[keep]]))

        def place_label(name: str, x: float, y: float, r: float, text: str) -> None:
            label = self.cam_labels[name]
            label.set_position((x + r + 0.4, y - r - 0.2))
            label.set_text(text)
            label.set_visible(True)

        self.ring.set_visible(False)
        for label in self.cam_labels.values():
            label.set_visible(False)
        target_in_view = False
        r_sc = data.spacecraft_km
        if len(data.planet_names):
            rel = data.planet_km - r_sc
            dist = np.linalg.norm(rel, axis=1)
            px, py, pfront = camera_angles_deg(data, rel / dist[:, None])
            for i, name in enumerate(data.planet_names):
                r_deg = max(
                    float(np.degrees(np.arcsin(min(data.planet_radii_km[i] / dist[i], 1.0)))), MIN_DISK_DEG
                )
                inside = bool(pfront[i] and abs(px[i]) <= vx + r_deg and abs(py[i]) <= vy + r_deg)
                disk = self.disks[i]
                disk.set_visible(inside)
                if inside:
                    disk.center = (px[i], py[i])
                    disk.set_radius(r_deg)
                    place_label(name, px[i], py[i], r_deg, f"{_pretty(name)} ({_fmt_km(dist[i])})")
                if name == data.target and inside:
                    target_in_view = True
                    self.ring.center = (px[i], py[i])
                    self.ring.set_radius(r_deg + 0.8)
                    self.ring.set_visible(True)
        self.pulsar_marks.set_data([], [])
        if len(data.pulsar_names):
            qx, qy, qfront = camera_angles_deg(data, data.pulsar_dirs)
            shown = qfront & (np.abs(qx) <= vx) & (np.abs(qy) <= vy)
            self.pulsar_marks.set_data(qx[shown], qy[shown])
            for i, name in enumerate(data.pulsar_names):
                if shown[i]:
                    place_label(name, qx[i], qy[i], 0.3, f"pulsar {name}")
                if name == data.target and shown[i]:
                    target_in_view = True
                    self.ring.center = (qx[i], qy[i])
                    self.ring.set_radius(1.0)
                    self.ring.set_visible(True)

        # The Sun (the exclusion cone's centre), when within the panel.
        sun_x, sun_y, sun_front = camera_angles_deg(data, -r_sc / np.linalg.norm(r_sc))
        sun_in = bool(sun_front[0] and abs(sun_x[0]) <= vx and abs(sun_y[0]) <= vy)
        self.sun_disk.set_visible(sun_in)
        self.sun_label.set_visible(sun_in)
        if sun_in:
            self.sun_disk.center = (sun_x[0], sun_y[0])
            self.sun_disk.set_radius(1.0)
            self.sun_label.set_position((sun_x[0] + 1.2, sun_y[0]))

        # A target outside the panel (mid-slew): an arrow toward it, with its angle off the boresight.
        self.pointer.set_visible(False)
        self.pointer_label.set_visible(False)
        if data.target is not None and not target_in_view:
            v = _camera_vector(data, _target_direction(data))
            n = float(np.hypot(v[0], v[1])) or 1.0
            ux, uy = v[0] / n, v[1] / n
            s = 0.85 / max(abs(ux) / vx, abs(uy) / vy)  # to 85 % of the way to the panel's edge
            tip, tail = (ux * s, uy * s), (ux * s * 0.5, uy * s * 0.5)
            self.pointer.set_positions(tail, tip)
            off = float(np.degrees(np.arccos(np.clip(v[2], -1.0, 1.0))))
            self.pointer_label.set_position((tail[0], tail[1] - 0.1 * vy * (1.0 if uy >= 0 else -1.0)))
            self.pointer_label.set_text(f"{_pretty(data.target)}: {off:.0f}° off")
            self.pointer.set_visible(True)
            self.pointer_label.set_visible(True)

        state = "measured" if data.measured else f"no measurement ({data.visibility})"
        self.cam_status.set_text(f"last step: {state}")
        return (vx, vy)

    # -- error -------------------------------------------------------------------------------------------
    def _build_error(self) -> None:
        ax = self.err
        ax.set_yscale("log")
        ax.set_xlabel("time since start [h]")
        ax.set_ylabel("position [km]")
        ax.set_title("Navigation error", fontsize=10)
        ax.grid(True, which="major", alpha=0.4)
        ax.grid(True, which="minor", alpha=0.12)
        (self.err_line,) = ax.plot([], [], color=ERROR_COLOR, lw=1.6, label="true error |r_est - r_true|")
        (self.sig_line,) = ax.plot(
            [], [], color=SIGMA_COLOR, lw=1.6, ls="--", label="filter 1-sigma sqrt(tr P_rr)"
        )
        self._dyn(self.err_line)
        self._dyn(self.sig_line)
        ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
        self.err_now = self._dyn(ax.text(
            0.02, 0.03, "", transform=ax.transAxes, fontsize=8.5, va="bottom",
            bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "#999999", "alpha": 0.85},
        ))  # fmt: skip

    def _update_error(self, data: FrameData) -> tuple:
        hist = np.asarray(data.history_km, dtype=float).reshape(-1, 2)
        t_h = np.arange(len(hist)) * data.step_s / 3600.0
        self.err_line.set_data(t_h, hist[:, 0])
        self.sig_line.set_data(t_h, hist[:, 1])
        # The axis grows with the episode (at least 20 steps wide): an early frame fills the panel instead
        # of a few pixels at the left of a full-episode axis.
        x_max = _nice_ceil(max(len(hist) - 1, 20) * data.step_s / 3600.0)
        vals = hist[np.isfinite(hist) & (hist > 0)]
        lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (1.0, 10.0)
        # Whole decades, and one more on top for the legend.
        y_lim = (10.0 ** np.floor(np.log10(lo / 1.5)), 10.0 ** (np.ceil(np.log10(hi)) + 1))
        _set_limits(self.err, (0.0, x_max), y_lim)
        if len(hist):
            self.err_now.set_text(
                f"step {data.step}/{data.episode_steps}: error {_fmt_km(hist[-1, 0])}, "
                f"1-sigma {_fmt_km(hist[-1, 1])}"
            )
        return (x_max, *y_lim)

    # -- orbit -------------------------------------------------------------------------------------------
    def _build_orbit(self, planet_names: tuple[str, ...], pulsar_names: tuple[str, ...]) -> None:
        ax = self.orb
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("ecliptic x [AU]")
        ax.set_ylabel("ecliptic y [AU]")
        ax.set_title("Orbit (heliocentric, ecliptic J2000)", fontsize=10)
        ax.grid(True, alpha=0.25)
        ax.plot([0], [0], marker="o", ms=11, color="#fbc02d", mec="#f57f17", zorder=4)
        ax.text(0.0, 0.0, "  Sun", fontsize=8.5, va="center", zorder=5)
        self.orbit_rings: list[Circle] = []
        self.orbit_marks: list[Any] = []
        self.orbit_labels: list[Any] = []
        for name in planet_names:
            ring = self._dyn(Circle((0, 0), 1, fill=False, ec="#bbbbbb", lw=0.8, ls=":", zorder=1))
            ax.add_patch(ring)
            self.orbit_rings.append(ring)
            color = PLANET_COLORS.get(name, "#888888")
            (mark,) = ax.plot([], [], marker="o", ms=7, color=color, mec="black", mew=0.5, zorder=4)
            self.orbit_marks.append(self._dyn(mark))
            self.orbit_labels.append(
                self._dyn(ax.text(0, 0, _pretty(name), fontsize=8.5, zorder=5, clip_on=True))
            )
        self.psr_arrows = []
        for name in pulsar_names:
            arrow = FancyArrowPatch(
                (0, 0), (1, 1), arrowstyle="-|>", mutation_scale=10, color=PULSAR_COLOR, lw=1
            )
            ax.add_patch(self._dyn(arrow))
            label = self._dyn(
                ax.text(0, 0, f"to pulsar {name}", fontsize=7.5, color=PULSAR_COLOR, clip_on=True)
            )
            self.psr_arrows.append((arrow, label))
        (self.sc_mark,) = ax.plot([], [], marker="D", ms=6, color="black", ls="none", zorder=7)
        self._dyn(self.sc_mark)
        self.sc_label = self._dyn(ax.text(
            0, 0, "", fontsize=8.5, weight="bold", ha="right", va="top", zorder=8, clip_on=True
        ))  # fmt: skip
        (self.inset_link,) = ax.plot([], [], color="#777777", lw=0.8, transform=ax.transAxes, zorder=9)
        self._dyn(self.inset_link)
        # The error ellipse at true scale in an inset about the spacecraft: at 1 AU it is far below a pixel.
        # The inset is drawn whole every frame (its limits follow the ellipse), after the orbit's artists.
        self.inset = self._dyn(self.fig.add_axes(self._inset_rect(0.6, 0.04), zorder=10))
        ins = self.inset
        ins.set_aspect("equal", adjustable="datalim")
        # No axes, ticks or legend (the inset is drawn every frame: text and tick machinery cost most); a
        # plain frame, the title states the box's half width, the orbit's legend names the markers.
        ins.set_axis_off()
        ins.add_patch(
            Rectangle(
                (0, 0), 1, 1, transform=ins.transAxes, fc="white", ec="black", lw=0.8, zorder=0, clip_on=False
            )
        )
        self.inset_title = ins.text(
            0.5, 1.0, "", transform=ins.transAxes, fontsize=7.5, ha="center", va="bottom",
            bbox={"boxstyle": "square,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},
        )  # fmt: skip
        ins.axhline(0.0, color="#dddddd", lw=0.6, zorder=0)
        ins.axvline(0.0, color="#dddddd", lw=0.6, zorder=0)
        self.ellipse = Ellipse((0, 0), 1, 1, fc=SIGMA_COLOR, alpha=0.3, ec=SIGMA_COLOR, lw=1.2)
        ins.add_patch(self.ellipse)
        (self.ins_sc,) = ins.plot([0], [0], marker="D", ms=5, color="black", ls="none")
        (self.est_mark,) = ins.plot([], [], marker="x", ms=7, mew=2, color=ERROR_COLOR, ls="none")
        ax.legend(
            [self.ins_sc, self.est_mark, Ellipse((0, 0), 1, 1, fc=SIGMA_COLOR, alpha=0.3, ec=SIGMA_COLOR)],
            ["spacecraft (truth)", "estimate (zoom)", "filter 1-sigma (zoom)"],
            loc="upper left", fontsize=7, framealpha=0.85, handlelength=1.2, borderpad=0.3, labelspacing=0.2,
        )  # fmt: skip
        self.inset_text = ins.text(
            0.5, 0.02, "", transform=ins.transAxes, fontsize=6.5, ha="center", va="bottom"
        )

    def _update_orbit(self, data: FrameData) -> tuple:
        ax = self.orb
        sc = ecliptic_xy_au(data.spacecraft_km)
        planets = ecliptic_xy_au(data.planet_km).reshape(-1, 2)
        radius = max(
            float(np.max(np.linalg.norm(planets, axis=1))) if len(planets) else 0.0,
            float(np.linalg.norm(sc)),
            0.5,
        )
        lim = _nice_ceil(1.2 * radius)
        _set_limits(ax, (-lim, lim), (-lim, lim))
        for i in range(len(planets)):
            self.orbit_rings[i].set_radius(float(np.linalg.norm(planets[i])))
            self.orbit_marks[i].set_data([planets[i, 0]], [planets[i, 1]])
            self.orbit_labels[i].set_position((planets[i, 0] + 0.04 * lim, planets[i, 1] + 0.04 * lim))
        psr_tips = []  # the inset avoids them too
        for i, (arrow, text) in enumerate(self.psr_arrows):
            d = ecliptic_xy_au(data.pulsar_dirs[i] * AU_KM)
            d = d / (np.linalg.norm(d) or 1.0)
            # Pulsars are at infinity: their direction is the same from anywhere, so it is drawn from the Sun,
            # where there is room for it.
            tip = 0.6 * lim * d
            psr_tips.extend([(0.35 * lim * d)[None], tip[None]])
            arrow.set_positions(tuple(0.1 * lim * d), tuple(tip))
            text.set_position(tuple(tip + 0.03 * lim * d))
            text.set_ha("left" if d[0] >= 0 else "right")
            text.set_va("bottom" if d[1] >= 0 else "top")
        self.sc_mark.set_data([sc[0]], [sc[1]])
        self.sc_label.set_position((sc[0] - 0.04 * lim, sc[1] - 0.04 * lim))
        sc_text = "spacecraft"
        if data.central != "sun":
            rng = float(np.linalg.norm(data.spacecraft_km - _central_km(data)))
            sc_text += f"\n{_fmt_km(rng)} from {_pretty(data.central)}"
        self.sc_label.set_text(sc_text)

        # The inset goes in the emptiest corner (fewest bodies; the legend holds the top left), linked to the
        # spacecraft by a line.
        pts = np.vstack([planets, sc[None], np.zeros((1, 2)), *psr_tips]) / lim  # in [-1, 1]
        corners = ((0.6, 0.04), (0.02, 0.04), (0.6, 0.58))
        centres = np.array([[0.5, -0.5], [-0.5, -0.5], [0.5, 0.5]])
        crowd = [int(np.sum(np.all(np.abs(pts - c) < 0.55, axis=1))) for c in centres]
        x0, y0 = corners[int(np.argmin(crowd))]
        rect = self._inset_rect(x0, y0)
        self.inset.set_position(rect)
        sc_axes = (sc + lim) / (2 * lim)
        half_w = INSET_FRACTION / 2  # the link ends on the inset corner nearest the spacecraft
        near = (
            x0 + half_w + half_w * np.sign(sc_axes[0] - x0 - half_w),
            y0 + half_w + half_w * np.sign(sc_axes[1] - y0 - half_w),
        )
        self.inset_link.set_data([sc_axes[0], near[0]], [sc_axes[1], near[1]])

        major_km, minor_km, angle = ellipse_ecliptic(data.position_cov_km2)
        off = ecliptic_xy_au(data.estimate_km - data.spacecraft_km) * AU_KM
        self.ellipse.set_width(2 * major_km)
        self.ellipse.set_height(2 * minor_km)
        self.ellipse.set_angle(angle)
        self.est_mark.set_data([off[0]], [off[1]])
        half = _nice_ceil(max(1.6 * major_km, 1.25 * float(np.max(np.abs(off))), 1e-3))
        _set_limits(self.inset, (-half, half), (-half, half))
        self.inset_title.set_text(f"zoom: ±{_fmt_km(half)} about spacecraft")
        self.inset_text.set_text(f"1-sigma {_fmt_km(major_km)} x {_fmt_km(minor_km)}")
        return (lim,)

    def _inset_rect(self, x0: float, y0: float) -> tuple[float, float, float, float]:
        """Figure coordinates of an inset at (x0, y0) in the orbit axes' fraction (the axes' box is fixed:
        their aspect adjusts the data limits)."""
        b = self.orb.get_position()
        return (
            b.x0 + x0 * b.width,
            b.y0 + y0 * b.height,
            INSET_FRACTION * b.width,
            INSET_FRACTION * b.height,
        )

    # -- frame -------------------------------------------------------------------------------------------
    def update(self, data: FrameData) -> None:
        """Set every artist to ``data`` and draw: the background again only when an axis limit changed."""
        self.title.set_text(
            f"{data.title}    t = {data.time_s / 3600.0:.2f} h (step {data.step} of {data.episode_steps})"
        )
        key = (self._update_camera(data), self._update_error(data), self._update_orbit(data))
        canvas = self.fig.canvas
        if key != self._background_key:
            canvas.draw()  # everything not animated
            self._background = canvas.copy_from_bbox(self.fig.bbox)
            self._background_key = key
        else:
            canvas.restore_region(self._background)
        for artist in self.dynamic:
            self.fig.draw_artist(artist)

    def rgb(self) -> np.ndarray:
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()


def _set_limits(ax: Any, xlim: tuple[float, float], ylim: tuple[float, float]) -> None:
    """Set axis limits only when they change: setting them invalidates every transform of the axes, which
    costs more than drawing a frame's markers."""
    if ax.get_xlim() != tuple(xlim):
        ax.set_xlim(*xlim)
    if ax.get_ylim() != tuple(ylim):
        ax.set_ylim(*ylim)


def _target_direction(data: FrameData) -> np.ndarray:
    """ICRF unit vector from the spacecraft to the target (a planet or a pulsar)."""
    if data.target in data.planet_names:
        rel = data.planet_km[data.planet_names.index(data.target)] - data.spacecraft_km
        return rel / np.linalg.norm(rel)
    return data.pulsar_dirs[data.pulsar_names.index(data.target)]


def _camera_vector(data: FrameData, d_icrf: np.ndarray) -> np.ndarray:
    """An ICRF direction in camera axes (true attitude)."""
    return qt.rotate_inertial_to_body(data.attitude_q, d_icrf) @ data.camera.camera_to_body_matrix


def _central_km(data: FrameData) -> np.ndarray:
    """Heliocentric position [km] of the central body (the Sun: the origin)."""
    if data.central in data.planet_names:
        return data.planet_km[data.planet_names.index(data.central)]
    return np.zeros(3)


def _pretty(name: str | None) -> str:
    """Display name: planets capitalised, pulsar designations as given."""
    if name is None:
        return "none"
    return name.capitalize() if name.isalpha() else name


# Figures are reused per beacon layout (building one costs ~10 frames); a few layouts at most per process.
_CANVASES: OrderedDict[tuple[tuple[str, ...], tuple[str, ...]], _Canvas] = OrderedDict()
_MAX_CANVASES = 4
_LOCK = threading.Lock()  # a matplotlib figure is not thread safe; envs in threads share the cache


def _canvas_for(data: FrameData) -> _Canvas:
    key = (tuple(data.planet_names), tuple(data.pulsar_names))
    canvas = _CANVASES.get(key)
    if canvas is None:
        canvas = _Canvas(*key)
        _CANVASES[key] = canvas
        while len(_CANVASES) > _MAX_CANVASES:
            _CANVASES.popitem(last=False)
    _CANVASES.move_to_end(key)
    return canvas


def figure_for(data: FrameData) -> Figure:
    """The (shared, reused) matplotlib figure updated to ``data`` and drawn, to inspect its axes, labels and
    legends (tests). Its moving artists are ``animated`` (blitted), so ``savefig`` leaves them out: save the
    array of :func:`render_frame` instead. The next frame of the same beacon layout overwrites it."""
    with _LOCK:
        canvas = _canvas_for(data)
        canvas.update(data)
        return canvas.fig


def render_frame(data: FrameData) -> np.ndarray:
    """The frame of ``data``: (height, width, 3) uint8 RGB, ``FRAME_SIZE_PX = (width, height)``."""
    with _LOCK:
        canvas = _canvas_for(data)
        canvas.update(data)
        return canvas.rgb()


# ---------------------------------------------------------------------------------------------------------
# command line: one frame of a short rollout, as a PNG


def scripted_action(action_space: Any, step: int, rng: np.random.Generator, hold: int = 100) -> Any:
    """The CLI's policy: with a discrete action space, cycle through the targets, ``hold`` steps each (so a
    frame shows slews and measurements of every beacon); otherwise a uniform sample of the space."""
    n = getattr(action_space, "n", None)
    if n is not None:
        return int((step // hold) % int(n))
    return rng.uniform(action_space.low, action_space.high).astype(action_space.dtype)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m planetnav_env.envs.render",
        description="Save one rgb_array frame of a scripted rollout.",
    )
    parser.add_argument("--id", default="planetnav/Cruise-Target-v0", help="registered environment id")
    parser.add_argument("--steps", type=int, default=300, help="steps before the frame is taken")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hold", type=int, default=100, help="steps per target of the cycling policy")
    parser.add_argument("--out", default="render_frame.png", help="PNG path")
    args = parser.parse_args(argv)

    import gymnasium as gym
    import matplotlib.image

    import planetnav_env  # noqa: F401  (registers the ids; the env module comes in through gym.make)

    env = gym.make(args.id, render_mode="rgb_array")
    env.reset(seed=args.seed)
    rng = np.random.default_rng(args.seed)
    for step in range(args.steps):
        _, _, terminated, truncated, _ = env.step(scripted_action(env.action_space, step, rng, args.hold))
        if terminated or truncated:
            break
    matplotlib.image.imsave(args.out, env.render())
    env.close()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
