"""The flight world's camera truth, in numbers: what each camera effect amounts to on the scenarios'
geometry (the reset state of seed 0 and, on the Mars approach, the episode's last step).

    python research/flight_world/camera_magnitudes.py

Printed per scenario and planet: range, disk diameter [px], phase, the image's SNR, the image-driven
centroid sigma ["] and diameter sigma [px] against the filter's R (3.5" and 2.5 px), the Lambertian
centre-of-brightness offset ["] and what the photometric model's error bound leaves of it, the boresight
drift's sigma, and the range bias a spherical model takes from an oblate outline [km] (seen from the
planet's equator, the largest). Then the spread between the two classical scattering laws' centres of
brightness (Lambert and Lommel-Seeliger, rendered), which the photometric model's error bound is
reasoned from.
"""

from __future__ import annotations

import math

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.sensors.image_noise import (
    centroid_sigma_px,
    diameter_sigma_px,
    image_snr,
    planet_electrons,
)
from planetnav_env.sensors.photometry import GEOMETRIC_ALBEDO, lambert_cob_offset

ARCSEC = math.pi / 648_000.0
SCENARIOS = {"cruise": "planetnav/Cruise-Target-v2", "mars-approach": "planetnav/MarsApproach-Tasking-v2"}


def rendered_cob(phase: float, law: str, pixels: int = 1201) -> float:
    """Centre of brightness [disk radii] of a rendered sphere at ``phase`` [rad]: Lambert (radiance
    mu0) or Lommel-Seeliger (mu0 / (mu0 + mu)), orthographic."""
    u = (np.arange(pixels) + 0.5) / pixels * 2.0 - 1.0
    x, y = np.meshgrid(u, u)
    inside = x * x + y * y < 1.0
    mu = np.sqrt(np.where(inside, 1.0 - x * x - y * y, 0.0))
    mu0 = np.maximum(x * math.sin(phase) + mu * math.cos(phase), 0.0)
    if law == "lambert":
        rad = np.where(inside, mu0, 0.0)
    else:
        rad = np.where(inside & (mu0 > 0.0), mu0 / np.maximum(mu0 + mu, 1e-300), 0.0)
    return float((rad * x).sum() / rad.sum())


def rows(env_id: str, at_end: bool) -> list[tuple]:
    cfg = EnvConfig.from_dict({**ENV_IDS[env_id], "world": "flight"})
    core = BatchCore(cfg, 1)
    core.reset_rows(np.array([0]), [np.random.default_rng(0)])
    if at_end:  # hold the first planet (Mars on the approach) to the last step
        for _ in range(cfg.episode_decisions - 1):
            core.step(np.zeros((1, 1)))
    bodies = core.body_positions(0)
    r = core.f[0, L.F_X : L.F_X + 3] + bodies["central"]
    w, cam = cfg.world, cfg.camera
    collect = math.pi * (0.5e-3 * w.aperture_mm) ** 2 * w.exposure_s
    out = []
    for name, pl in zip(cfg.planets, bodies["planets"], strict=True):
        b = body(name)
        d = pl - r
        dist = float(np.linalg.norm(d))
        cos_phase = float(np.dot(pl, d) / (np.linalg.norm(pl) * dist))
        alpha = 2.0 * math.asin(b.radius / dist)
        d_px = alpha * cam.f_px
        e = planet_electrons(
            GEOMETRIC_ALBEDO[name], b.radius, float(np.linalg.norm(pl)), dist, cos_phase, collect
        )
        snr = image_snr(e, d_px, w.psf_sigma_px, w.full_well_e, w.read_noise_e)
        args = (d_px, snr, w.psf_sigma_px, w.centroid_floor_px, w.limb_scatter)
        s_c = centroid_sigma_px(*args) / cam.f_px / ARCSEC
        s_d = diameter_sigma_px(*args)
        cob = lambert_cob_offset(cos_phase) * 0.5 * alpha / ARCSEC
        range_bias = dist * (1.0 - math.sqrt(b.polar_radius / b.radius))
        out.append((name, dist, d_px, math.degrees(math.acos(cos_phase)), snr, s_c, s_d, cob, range_bias))
    return out


def main() -> None:
    w = EnvConfig(world="flight").world
    print(f"boresight drift: {w.drift_sigma_arcsec} arcsec per axis, tau {w.drift_tau_s / 3600:.1f} h\n")
    for scenario, env_id in SCENARIOS.items():
        for at_end in (False, True) if scenario == "mars-approach" else (False,):
            when = "last step" if at_end else "reset"
            print(f"{scenario} ({env_id}, seed 0, {when})\n")
            print(
                '| planet | range [km] | D [px] | phase [deg] | SNR | centroid sigma ["] | diameter sigma '
                '[px] | CoB offset ["] | left at the model error bound ["] | oblate range bias [km] |'
            )
            print("|---|---|---|---|---|---|---|---|---|---|")
            for name, dist, d_px, ph, snr, s_c, s_d, cob, rb in rows(env_id, at_end):
                print(
                    f"| {name} | {dist:.3g} | {d_px:.3g} | {ph:.0f} | {snr:.0f} | {s_c:.2f} | {s_d:.3g} "
                    f"| {cob:.2f} | {w.cob_model_error * cob:.2f} | {rb:.0f} |"
                )
            print()
    print("centre of brightness [disk radii], rendered: Lambert, Lommel-Seeliger, their relative gap\n")
    print("| phase [deg] | Lambert | Lommel-Seeliger | gap |")
    print("|---|---|---|---|")
    for p in (20, 45, 60, 90, 120, 150):
        a, b = rendered_cob(math.radians(p), "lambert"), rendered_cob(math.radians(p), "ls")
        print(f"| {p} | {a:.4f} | {b:.4f} | {b / a - 1.0:+.3f} |")


if __name__ == "__main__":
    main()
