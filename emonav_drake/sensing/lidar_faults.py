"""The faults of a real LiDAR, applied to one exact scan of its own beams (numpy only).

`apply_faults` turns the exact ranges of the sensor's N beams (equally spaced over the
full turn, `sensing/lidar.py`'s beam convention with K = N) into what the sensor reports,
with the `SensorParams` of the configuration (docs/perception.md, "The LiDAR as a
sensor"). Per beam, in this order:

1. **Mixed pixels.** A beam at a range jump — its exact range and a neighbour's, both
   hits, differ by more than `MIXED_PIXEL_JUMP` (two surfaces, an object's edge) — has a
   footprint on both surfaces; with probability `mixed_pixel_rate` it returns
   r_near + w·(r_far − r_near), w uniform in [0, 1), between the two surfaces (its
   neighbour across the larger jump).
2. **Dropouts.** A hit is lost with probability

       1 − (1 − dropout_rate)·(1 − grazing_dropout·(1 − cos α)²)·(1 − far_dropout·(r/R)²)

   with α the incidence angle and R the rated range (the last factor capped at 1). α
   comes from the exact range profile: for beam spacing δθ, tan α = |dr/dθ| / r, with
   dr/dθ the smaller of the two one-sided differences to a neighbour that is a hit (at an
   edge, the side across the jump is not the surface's slope; a beam with no neighbour on
   its surface counts as grazing). A lost beam returns `max_range` ("nothing").
3. **Range error.** A return gets `range_bias` + N(0, `range_noise_std`²), then is rounded
   to a multiple of `range_resolution` (when > 0).
4. **Spurious returns.** With probability `spurious_rate`, any beam (a hit, a lost one or
   one that saw nothing) returns a range uniform between `min_range` and the range it
   would have returned: a short return from dust, rain or another sensor.
5. Every range is clipped to [min_range, max_range]; `max_range` means "nothing".

The random numbers are six arrays of N draws, in a fixed order, from `noise_rng(sensor
seed, scenario seed, time)`: every draw is made whatever the scene, so a scan is a pure
function of the scene, the seeds and the time (the Drake diagram, a cache re-evaluation
and the Gymnasium environment get the same scan).
"""

from __future__ import annotations

import numpy as np

from emonav_drake.params import SensorParams

# Neighbouring exact ranges farther apart than this [m] are two surfaces (an edge): a
# surface seen at a slant differs by r·δθ·tan α, 0.12 m at 6 m and 80° with 0.2° beams.
MIXED_PIXEL_JUMP = 0.3


def noise_rng(sensor_seed: int, scenario_seed: int, time: float) -> np.random.Generator:
    """The generator of one scan: `default_rng([sensor seed, scenario seed, time in ms])`
    (seeds taken modulo 2**64, the time [s] rounded to whole milliseconds)."""
    ms = round(float(time) * 1000.0)
    if ms < 0:
        raise ValueError(f"the scan's time must be >= 0, got {time} s")
    return np.random.default_rng([int(sensor_seed) % 2**64, int(scenario_seed) % 2**64, ms])


def _neighbour_gaps(exact: np.ndarray, hit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|r_j − r_{j−1}| and |r_{j+1} − r_j| around the full turn (N,) [m]; inf where the
    neighbour (or the beam) saw nothing."""
    prev_r, next_r = np.roll(exact, 1), np.roll(exact, -1)
    prev_gap = np.where(hit & np.roll(hit, 1), np.abs(exact - prev_r), np.inf)
    next_gap = np.where(hit & np.roll(hit, -1), np.abs(next_r - exact), np.inf)
    return prev_gap, next_gap


def incidence_cosines(exact: np.ndarray, step: float, max_range: float) -> np.ndarray:
    """cos α (N,) of each beam's incidence angle from the exact range profile [m] of beams
    `step` [rad] apart (module docstring, item 2); 1 where the beam saw nothing."""
    hit = exact < max_range
    prev_gap, next_gap = _neighbour_gaps(exact, hit)
    slope = np.minimum(prev_gap, next_gap) / step  # |dr/dθ| [m/rad], inf: no surface
    with np.errstate(invalid="ignore", divide="ignore"):
        tan = slope / exact
        cos = np.where(np.isinf(tan), 0.0, 1.0 / np.sqrt(1.0 + tan * tan))
    return np.where(hit, cos, 1.0)


def edge_partners(exact: np.ndarray, max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """(is_edge (N,) bool, partner (N,) [m]): the beams at a range jump larger than
    `MIXED_PIXEL_JUMP` to a neighbour that is a hit too, and that neighbour's exact range
    (across the larger jump when both sides jump)."""
    hit = exact < max_range
    prev_gap, next_gap = _neighbour_gaps(exact, hit)
    prev_gap = np.where(np.isinf(prev_gap), 0.0, prev_gap)
    next_gap = np.where(np.isinf(next_gap), 0.0, next_gap)
    partner = np.where(prev_gap >= next_gap, np.roll(exact, 1), np.roll(exact, -1))
    edge = np.maximum(prev_gap, next_gap) > MIXED_PIXEL_JUMP
    return edge, partner


def dropout_probability(
    exact: np.ndarray, cos_incidence: np.ndarray, sensor: SensorParams
) -> np.ndarray:
    """Probability (N,) that each return is lost (module docstring, item 2): exact ranges
    [m], cos of the incidence angles, the sensor's rates and rated range [m]."""
    grazing = sensor.grazing_dropout * (1.0 - cos_incidence) ** 2
    far = np.minimum(sensor.far_dropout * (exact / sensor.rated_range) ** 2, 1.0)
    return 1.0 - (1.0 - sensor.dropout_rate) * (1.0 - grazing) * (1.0 - far)


def apply_faults(
    exact: np.ndarray,
    step: float,
    sensor: SensorParams,
    min_range: float,
    max_range: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """What the sensor reports for the exact ranges of its beams (module docstring).

    Args:
        exact: (N,) exact ranges [m] of the sensor's beams, in [min_range, max_range]
            (`max_range`: nothing hit), consecutive beams `step` [rad] apart, wrapping
            around the full turn.
        step: the angle between neighbouring beams [rad].
        sensor: the fault model's parameters.
        min_range, max_range: the LiDAR's clipping limits [m].
        rng: the scan's generator (`noise_rng`); 6·N draws are taken from it.

    Returns:
        (N,) float64 reported ranges [m] in [min_range, max_range].
    """
    exact = np.asarray(exact, dtype=np.float64)
    n = exact.size
    u_mixed, w_mixed = rng.random(n), rng.random(n)
    u_drop = rng.random(n)
    noise = rng.standard_normal(n)
    u_spur, w_spur = rng.random(n), rng.random(n)

    hit = exact < max_range
    ranges = exact.copy()
    edge, partner = edge_partners(exact, max_range)
    mixed = edge & (u_mixed < sensor.mixed_pixel_rate)
    near, far = np.minimum(exact, partner), np.maximum(exact, partner)
    ranges[mixed] = (near + w_mixed * (far - near))[mixed]

    p_drop = dropout_probability(exact, incidence_cosines(exact, step, max_range), sensor)
    dropped = hit & (u_drop < p_drop)

    ranges += sensor.range_bias + sensor.range_noise_std * noise
    q = sensor.range_resolution
    if q > 0.0:
        ranges = np.round(ranges / q) * q
    ranges[dropped | ~hit] = max_range
    np.clip(ranges, min_range, max_range, out=ranges)

    spur = u_spur < sensor.spurious_rate
    ranges[spur] = (min_range + w_spur * (ranges - min_range))[spur]
    return ranges
