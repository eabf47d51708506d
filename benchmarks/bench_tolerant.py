"""How much clipping each N tolerates: saturation-tolerant decoding on the virtual rig, measured.

A white plate (64 x 48 px camera, pitch 16 px, read and shot noise, the rig's defaults) is
captured with the camera aperture opened step by step (``white_level`` x 1 .. x 16), so that
its pixels clip in 0, 1, 2, ... of their N shifts. Every capture is read twice from the same
noise-free signal with independent noise: once by the 8-bit camera (clipping at 255) and once
by a camera that does not clip (same read noise and shot-noise gain, 16-bit container). Per
number k of clipped shifts, over every aperture and draw, the phase error against the known
phase ``2 pi u / p`` (its mean removed) gives three standard deviations:

* ``tolerant``: :func:`hdrfringe.core.saturation.tolerant.tolerant_phase` on the clipped capture;
* ``all N``: Eq. 2.2 on the unclipped capture (the same pixels' noise floor with every shift);
* ``same shifts``: the unclipped capture decoded from the shifts the clipped one kept (the
  noise floor of what survives).

and the least-squares covariance's prediction for read noise alone
(:func:`hdrfringe.core.saturation.tolerant.tolerant_noise_gain` of the kept rows over its value for
all N, RMS over the pixels). docs/tolerant.md's table is this script's output
(``--markdown``); tests/test_tolerant.py reproduces one of its rows.

Run: ``.venv/bin/python benchmarks/bench_tolerant.py`` (about 10 s; ``--markdown`` prints the
table as docs/tolerant.md has it).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Sequence

import numpy as np

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import sinusoidal_phase
from hdrfringe.core.saturation.tolerant import tolerant_noise_gain, tolerant_phase
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.rig.sensor import sensor_readout

__all__ = ["APERTURES", "NS", "Row", "UnclippedCamera", "main", "markdown", "study"]

SEED = 20261130
NS = (3, 4, 5, 6, 8, 12)
RESOLUTION = (64, 48)
PITCH = 16.0
#: Aperture factors on the camera's white level (x1: the plate peaks at 80 % of full scale).
APERTURES = tuple(float(g) for g in np.geomspace(1.0, 16.0, 25))
DRAWS = 3
#: Fewest pixel samples (pixels x draws) for a row of the table.
MIN_SAMPLES = 200


@dataclasses.dataclass(frozen=True)
class UnclippedCamera:
    """A camera like the rig's that never clips: same read noise and shot-noise gain.

    Parameters
    ----------
    read_noise_dn : float
        Read-noise sigma in DN (the rig camera's).
    full_well_e : float or None
        Scaled so that the shot-noise gain ``full_scale / full_well`` is the rig camera's.
    full_scale : int
        65535: far above any signal here.
    dtype : type
        uint16.
    """

    read_noise_dn: float
    full_well_e: float | None
    full_scale: int = 65535
    dtype: type = np.uint16

    @classmethod
    def like(cls, camera) -> UnclippedCamera:
        """The unclipped twin of ``camera``."""
        well = camera.full_well_e
        return cls(camera.read_noise_dn, None if well is None else well * 65535 / camera.full_scale)


@dataclasses.dataclass(frozen=True)
class Row:
    """One line of the table: N, k clipped, samples and the three ratios."""

    n: int
    k: int
    samples: int
    tolerant_std: float
    all_n_std: float
    same_std: float
    ls_ratio: float

    @property
    def vs_all(self) -> float:
        """Tolerant std over the unclipped all-N std of the same pixels."""
        return self.tolerant_std / self.all_n_std

    @property
    def vs_same(self) -> float:
        """Tolerant std over the unclipped same-shift std of the same pixels."""
        return self.tolerant_std / self.same_std


def _wrapped(x: np.ndarray) -> np.ndarray:
    return np.mod(x + np.pi, 2 * np.pi) - np.pi


def _ls_gain(shifts: np.ndarray, keep: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """tolerant_noise_gain per pixel (keep: (M, P) rows used, phase: (P,)), NaN if unfit."""
    out = np.full(phase.shape, np.nan)
    codes, inverse = np.unique(np.packbits(keep, axis=0).T, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    for g in range(len(codes)):
        idx = np.flatnonzero(inverse == g)
        rows = keep[:, idx[0]]
        if rows.sum() < 3:
            continue
        out[idx] = tolerant_noise_gain(shifts, phase[idx], rows)
    return out


def study(
    n: int,
    *,
    resolution: tuple[int, int] = RESOLUTION,
    apertures: Sequence[float] = APERTURES,
    draws: int = DRAWS,
    seed: int = SEED,
) -> list[Row]:
    """The rows of one N: k = 0 .. N - 3 clipped shifts, where there are enough samples.

    Parameters
    ----------
    n : int
        Steps of the sinusoidal set.
    resolution : tuple of int
        Camera (width, height).
    apertures : sequence of float
        Factors on the camera's white level.
    draws : int
        Noise draws per aperture.
    seed : int
        Seed of the draws (one stream per N, aperture and draw).

    Returns
    -------
    list of Row
    """
    spec = FringeSpec("sinusoidal", n, PITCH)
    shifts = np.degrees(spec.shifts)
    errors: dict[int, list[np.ndarray]] = {}
    gains: dict[int, list[np.ndarray]] = {}
    for ia, factor in enumerate(apertures):
        rig = virtual_rig("white_plate", resolution=resolution)
        cam = dataclasses.replace(rig.camera, white_level=rig.camera.white_level * factor)
        rig = rig.replace(camera=cam)
        signal = rig.expected_signal(spec.frames())
        truth = 2 * np.pi * rig.truth().u / PITCH
        free_cam = UnclippedCamera.like(cam)
        for d in range(draws):
            rng = np.random.default_rng([seed, n, ia, d])
            clipped = sensor_readout(signal, cam, rng)
            free = sensor_readout(signal, free_cam, rng)
            kept = clipped < cam.full_scale
            k = (~kept).sum(axis=0)
            phi_t = tolerant_phase(clipped, shifts, cam.bit_depth)[0]
            phi_a = sinusoidal_phase(free)[0]
            masked = np.where(kept, np.minimum(free, 65534), 65535).astype(np.uint16)
            phi_s = tolerant_phase(masked, shifts, 16)[0]
            if d == 0:
                ls = _ls_gain(shifts, kept.reshape(n, -1), truth.ravel()).reshape(k.shape)
                ls /= np.sqrt(2.0 / n)
            for kk in np.unique(k):
                m = k == kk
                errors.setdefault(int(kk), []).append(
                    np.stack([_wrapped(p[m] - truth[m]) for p in (phi_t, phi_a, phi_s)])
                )
                if d == 0:
                    gains.setdefault(int(kk), []).append(ls[m])
    rows = []
    for kk in sorted(errors):
        if kk > n - 3:
            continue
        e = np.concatenate(errors[kk], axis=1)
        if e.shape[1] < MIN_SAMPLES:
            continue
        e = e - np.mean(e, axis=1, keepdims=True)
        s = np.std(e, axis=1)
        g = np.concatenate(gains[kk])
        rows.append(Row(n, kk, e.shape[1], *map(float, s), float(np.sqrt(np.mean(g**2)))))
    return rows


def markdown(rows: Sequence[Row]) -> str:
    """The table of docs/tolerant.md.

    Parameters
    ----------
    rows : sequence of Row

    Returns
    -------
    str
    """
    lines = [
        "| N | k clipped | samples | tolerant std (rad) | / unclipped, all N | "
        "/ unclipped, same shifts | LS, read noise only |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.n} | {r.k} | {r.samples} | {r.tolerant_std:.4f} | {r.vs_all:.2f} | "
            f"{r.vs_same:.2f} | {r.ls_ratio:.2f} |"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the study for every N and print the table.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true", help="print only the table")
    parser.add_argument("--steps", type=int, nargs="*", default=list(NS), help="the N to run")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    rows = [r for n in args.steps for r in study(n)]
    print(markdown(rows))
    if not args.markdown:
        print(f"\n{time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
