"""Flash detectors (Simi 2000): beacon-side detection, each event labelled and carrying the
laser's encoder-latched angle. Detection gives out past an incidence measured at two ranges:
a hard gate without light noise, else a response that falls to the trigger threshold there.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from arena.sensing.crossings import Crossings
from arena.sensing.optics import incidence, spot_width


def flash_limit(distance: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Simi's detectors: the largest detectable incidence, measured at two ranges ("44 deg at
    1 foot away and 27 deg at 7 feet away"), linear between and held beyond them: nothing
    outside the measured ranges is extrapolated."""
    d = np.clip(distance, p["near_range"], p["far_range"])
    slope = (p["far_incidence"] - p["near_incidence"]) / (p["far_range"] - p["near_range"])
    return p["near_incidence"] + slope * (d - p["near_range"])


def visible(c: Crossings, facing: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Which crossings pass the incidence limit: all of them with light noise (a soft limit:
    the optics decide, sweep by sweep), else those within `flash_limit`."""
    if p.get("light_noise", 0.0) > 0:
        return np.ones(len(c), dtype=bool)
    return incidence(c, facing) <= flash_limit(c.distance, p)


def sensitivity(c: Crossings, inc: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """The collector's response at this incidence, relative to head-on. It loses light with
    incidence ("a reduction in the laser beam intensity due to poor reflectivity on the
    plexiglass and an increase in the number of ricochets"), falling as a sensor array's does,
    scaled so that it just reaches the trigger threshold at the measured limit (flash_limit):
    S = S_limit^((incidence / limit)^2)."""
    limit = flash_limit(c.distance, p)
    w = spot_width(c.distance, p)
    a = p.get("aperture", 0.0) * np.cos(limit)
    with np.errstate(divide="ignore", invalid="ignore"):
        s_limit = np.minimum(1.0, p["trigger_fraction"] / np.where(w > a, a / w, 1.0))
        return np.where(limit > 0, s_limit ** ((inc / limit) ** 2), 0.0)
