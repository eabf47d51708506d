"""Acquire a program on the virtual rig as :class:`~hdrfringe.core.captures.Captures`, optionally
with light and noise added afterwards (thesis Eq. 4.1).

* :class:`IntensityModification`: the Eq. 4.1 parameters (added lux, DN, noise sigma, seed),
  validated, applied with :func:`hdrfringe.rig.modify.modify_captures`, and recorded in a
  manifest.
* :func:`simulated_captures`: capture frame by frame (a progress callback per frame), apply a
  modification, and keep what a capture folder records of the virtual rig: projector, scene,
  camera, and the scene's true height map.

Writing the result as a folder is I/O (:mod:`hdrfringe.tasks.simulate`).

Examples
--------
>>> from hdrfringe.core.patterns import FringeSpec
>>> from hdrfringe.rig.factory import virtual_rig
>>> caps = simulated_captures(virtual_rig("white_plate"), FringeSpec(steps=3).frames())
>>> caps.images.shape, sorted(caps.maps)
((3, 494, 648), ['truth_height_mm'])
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import Frame
from hdrfringe.errors import InputError
from hdrfringe.rig.modify import lux_to_dn, modify_captures
from hdrfringe.rig.simulated import SimulatedRig

__all__ = ["IntensityModification", "simulated_captures"]


@dataclass(frozen=True)
class IntensityModification:
    """Light and noise added to captured images, with clipping at ``2^B - 1`` (thesis Eq. 4.1).

    Parameters
    ----------
    add_lux : float
        Uniform illuminance added, in lux (0.17 8-bit gray levels per lux, scaled to B bits).
    add_dn : float
        Uniform intensity added, in DN of the images.
    noise_sigma : float
        Standard deviation of the added zero-mean Gaussian noise, in DN (>= 0).
    seed : int
        Noise seed (>= 0).

    Raises
    ------
    InputError
        A value that is not finite, a negative noise sigma or seed.

    References
    ----------
    Thesis Eq. 4.1, Sec. 4.3.1.

    Examples
    --------
    >>> m = IntensityModification(add_lux=600)
    >>> m.apply(np.array([100, 200], dtype=np.uint8), 8).tolist(), m.is_identity
    ([202, 255], False)
    >>> IntensityModification(seed=-1)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: seed must be a non-negative integer, got -1
    """

    add_lux: float = 0.0
    add_dn: float = 0.0
    noise_sigma: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("add_lux", "add_dn", "noise_sigma"):
            if not math.isfinite(getattr(self, name)):
                raise InputError(f"{name} must be a finite number, got {getattr(self, name)}")
        if self.noise_sigma < 0:
            raise InputError(f"noise_sigma must be >= 0, got {self.noise_sigma}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"seed must be a non-negative integer, got {self.seed!r}")

    @property
    def is_identity(self) -> bool:
        """True when nothing is added (the images are left as captured)."""
        return not (self.add_lux or self.add_dn or self.noise_sigma)

    def apply(self, images: NDArray[np.integer], bit_depth: int) -> NDArray[np.integer]:
        """The modified images (:func:`~hdrfringe.rig.modify.modify_captures`).

        Parameters
        ----------
        images : ndarray of unsigned integers
            Captured images, values in ``[0, 2^B - 1]``.
        bit_depth : int
            Camera bit depth B.

        Returns
        -------
        ndarray
            Same shape and dtype.
        """
        return modify_captures(
            images,
            bit_depth,
            add_dn=self.add_dn,
            add_lux=self.add_lux or None,
            noise_sigma=self.noise_sigma,
            seed=self.seed,
        )

    def to_manifest(self, *, with_seed: bool = True) -> dict[str, Any]:
        """The manifest's ``modification`` entry.

        Parameters
        ----------
        with_seed : bool
            Record the seed (``simulate`` leaves it out: its seed is the rig's).

        Returns
        -------
        dict

        Examples
        --------
        >>> IntensityModification(add_dn=3).to_manifest(with_seed=False)
        {'add_lux': 0.0, 'add_dn': 3.0, 'noise_sigma': 0.0, 'equation': 'thesis Eq. 4.1'}
        """
        entry: dict[str, Any] = {
            "add_lux": float(self.add_lux),
            "add_dn": float(self.add_dn),
            "noise_sigma": float(self.noise_sigma),
        }
        if with_seed:
            entry["seed"] = self.seed
        entry["equation"] = "thesis Eq. 4.1"
        return entry


def _modified_noise(
    camera: dict[str, Any], modification: IntensityModification, bit_depth: int
) -> dict[str, Any]:
    """The camera entry with the noise model of the modified images.

    Eq. 4.1 adds ``D`` DN after the readout (no shot noise of its own) and Gaussian noise of
    ``sigma_n``, rounded again: at an image value ``I* = I + D`` the variance is
    ``r^2 + g (I* - D) + sigma_n^2 (+ 1/12 for the second rounding)``, the same line with
    ``r^2 - g D + sigma_n^2 (+ 1/12)`` at zero. When that is negative (much light added to
    a camera of little read noise) the line does not describe the images and the noise keys
    are left out (``phase`` and ``measure`` then estimate the noise from the images).
    """
    if "read_noise_dn" not in camera:
        return camera
    gain = float(camera.get("gain_dn_per_e", 0.0))
    added = modification.add_dn + (
        float(lux_to_dn(modification.add_lux, bit_depth)) if modification.add_lux else 0.0
    )
    var = float(camera["read_noise_dn"]) ** 2 - gain * added
    if modification.noise_sigma > 0:
        var += modification.noise_sigma**2 + 1.0 / 12.0
    out = {k: v for k, v in camera.items() if k not in ("read_noise_dn", "gain_dn_per_e")}
    if var >= 0:
        out["read_noise_dn"] = math.sqrt(var)
        out["gain_dn_per_e"] = gain
    return out


def simulated_captures(
    rig: SimulatedRig,
    frames: Sequence[Frame],
    *,
    modification: IntensityModification | None = None,
    progress: Callable[[], Any] | None = None,
) -> Captures:
    """Capture ``frames`` on the virtual rig, one at a time, and keep what a folder records.

    Parameters
    ----------
    rig : SimulatedRig
        The virtual rig (e.g. :func:`hdrfringe.rig.factory.virtual_rig`).
    frames : sequence of Frame
        The program, in play order.
    modification : IntensityModification, optional
        Eq. 4.1 applied to the captured stack (with the modification's seed).
    progress : callable, optional
        Called once per captured frame.

    Returns
    -------
    Captures
        Frames, images, the camera bit depth, the rig's projector, the scene's manifest entry,
        the camera description and the map ``truth_height_mm``.

    References
    ----------
    Thesis Eq. 3.3 (the rig's intensity), Eq. 4.1 (the modification).

    Examples
    --------
    >>> from hdrfringe.core.frames import UniformFrame
    >>> from hdrfringe.rig.factory import virtual_rig
    >>> rig = virtual_rig("white_plate", noise=0, shot_noise=False)
    >>> caps = simulated_captures(rig, [UniformFrame(255)], modification=IntensityModification(
    ...     add_lux=600))
    >>> int(caps.images.max()), caps.scene["name"]
    (255, 'white_plate')
    """
    frames = list(frames)
    if not frames:
        raise InputError("no frames to capture; give at least one frame")
    images = []
    for f in frames:
        images.append(rig.capture([f])[0])
        if progress is not None:
            progress()
    stack = np.stack(images)
    camera = rig.camera_manifest()
    if modification is not None and not modification.is_identity:
        stack = modification.apply(stack, rig.camera_bit_depth)
        camera = _modified_noise(camera, modification, rig.camera_bit_depth)
    return Captures(
        frames,
        stack,
        rig.camera_bit_depth,
        projector=rig.projector,
        scene=rig.scene.to_manifest(),
        camera=camera,
        maps={"truth_height_mm": rig.truth().height_mm},
    )
