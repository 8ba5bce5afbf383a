"""rgb_array frames: the synthetic camera image beside the navigation-error history.

Left (256 x 256): what the star camera sees, scaled from its sensor: star field (the star
tracker's catalogue), planet disks at their apparent size (at least 2 px so a sub-pixel planet
stays visible; the target is ringed), the field-of-view edge. Right (256 x 256): log10 of the true
position error (white) and of the filter's 1-sigma (green) over the episode so far.
Pure numpy: no plotting library in the step loop.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from planetnav_env import quaternion as qt

if TYPE_CHECKING:
    from planetnav_env.env import PlanetNavEnv

SIZE = 256
PLANET_COLORS = {
    "mercury": (180, 170, 160),
    "venus": (255, 200, 80),
    "earth": (80, 150, 255),
    "moon": (210, 210, 210),
    "mars": (230, 90, 60),
    "jupiter": (220, 180, 140),
    "saturn": (230, 210, 150),
}


def _disk(img: np.ndarray, cx: float, cy: float, r: float, color: tuple[int, int, int]) -> None:
    y0, y1 = int(max(cy - r - 1, 0)), int(min(cy + r + 2, SIZE))
    x0, x1 = int(max(cx - r - 1, 0)), int(min(cx + r + 2, SIZE))
    if y0 >= y1 or x0 >= x1:
        return
    yy, xx = np.mgrid[y0:y1, x0:x1]
    mask = (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r
    img[y0:y1, x0:x1][mask] = color


def _ring(img: np.ndarray, cx: float, cy: float, r: float, color: tuple[int, int, int]) -> None:
    ang = np.linspace(0, 2 * np.pi, 64)
    xs = np.clip((cx + r * np.cos(ang)).astype(int), 0, SIZE - 1)
    ys = np.clip((cy + r * np.sin(ang)).astype(int), 0, SIZE - 1)
    img[ys, xs] = color


def _camera_panel(env: PlanetNavEnv) -> np.ndarray:
    cfg = env.config.camera
    img = np.zeros((SIZE, SIZE, 3), dtype=np.uint8)
    w, h = cfg.resolution_px
    scale = SIZE / max(w, h)
    truth = env.truth
    q = truth["q"]  # the image is what the camera really sees
    stars = env.core.params.stars.dirs
    v_cam = cfg.camera_to_body_matrix.T @ qt.rotate_inertial_to_body(q, stars).T
    front = v_cam[2] > 0
    px = cfg.f_px * v_cam[0, front] / v_cam[2, front] + cfg.principal_point[0]
    py = cfg.f_px * v_cam[1, front] / v_cam[2, front] + cfg.principal_point[1]
    inside = (px >= 0) & (px < w) & (py >= 0) & (py < h)
    img[(py[inside] * scale).astype(int), (px[inside] * scale).astype(int)] = (200, 200, 200)
    bodies = env.body_positions()
    planets = bodies["planets"]  # heliocentric
    r_helio = truth["x"][:3] + bodies["central"]  # the truth is relative to the central body
    radii = env.core.params.radii
    for i, p in enumerate(planets):
        d = p - r_helio
        dist = np.linalg.norm(d)
        c = cfg.camera_to_body_matrix.T @ qt.rotate_inertial_to_body(q, d / dist)
        if c[2] <= 0:
            continue
        x = (cfg.f_px * c[0] / c[2] + cfg.principal_point[0]) * scale
        y = (cfg.f_px * c[1] / c[2] + cfg.principal_point[1]) * scale
        radius_px = max(np.arcsin(min(radii[i] / dist, 1.0)) * cfg.f_px * scale, 2.0)
        _disk(img, x, y, radius_px, PLANET_COLORS.get(env.planets[i], (200, 200, 200)))
        if i == env.target_index:
            _ring(img, x, y, radius_px + 5, (255, 255, 255))
    img[[0, -1], :] = (90, 90, 90)  # field-of-view edge
    img[:, [0, -1]] = (90, 90, 90)
    return img


def _history_panel(env: PlanetNavEnv) -> np.ndarray:
    img = np.full((SIZE, SIZE, 3), 20, dtype=np.uint8)
    hist = np.asarray(env.history, dtype=float)
    n_total = env.config.episode_steps + 1
    lo, hi = 0.0, 5.0  # log10 km: 1 km .. 100,000 km
    for level in range(6):
        y = int((SIZE - 1) * (1 - (level - lo) / (hi - lo)))
        img[min(max(y, 0), SIZE - 1), :] = (45, 45, 45)
    if len(hist) == 0:
        return img
    xs = (np.arange(len(hist)) / max(n_total - 1, 1) * (SIZE - 1)).astype(int)
    for col, color in ((1, (60, 200, 90)), (0, (255, 255, 255))):
        vals = np.log10(np.clip(hist[:, col], 10**lo, 10**hi))
        ys = ((SIZE - 1) * (1 - (vals - lo) / (hi - lo))).astype(int)
        img[ys, xs] = color
    return img


def render_frame(env: PlanetNavEnv) -> np.ndarray:
    """(256, 512, 3) uint8 frame."""
    return np.concatenate([_camera_panel(env), _history_panel(env)], axis=1)
