"""The virtual rig a handful of plain options describe (the ``simulate``, ``measure --rig sim``
and ``train-correction --rig sim`` commands, and any script).

:func:`virtual_rig` turns a scene name, its depth, the light and the camera options into a
:class:`~hdrfringe.rig.simulated.SimulatedRig`, with the aperture rule: the default camera is
set so that a white plate peaks at 80 % of full scale; the black plate and the checkerboard
(mostly dark) get the aperture opened for the black plate's reflectivity (thesis Sec. 5.2.2).

Examples
--------
>>> rig = virtual_rig("checkerboard", ambient_lux=600.0, seed=3)
>>> rig.lighting.ambient_lux, rig.camera_bit_depth, rig.seed
(600.0, 8, 3)
"""

from __future__ import annotations

import dataclasses
from typing import Any

from hdrfringe.errors import InputError
from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, make_scene
from hdrfringe.rig.simulated import THESIS_GAMMA, Lighting, SimulatedRig

__all__ = ["APERTURES", "BASE_SCENES", "DARK_SCENES", "virtual_rig"]

#: Aperture choices: ``auto`` opens it for :data:`DARK_SCENES` only.
APERTURES = ("auto", "white", "black")
#: Scenes the ``auto`` aperture treats as dark (aperture opened for the black plate).
DARK_SCENES = ("checkerboard", "black_plate")
#: Freeform scenes whose ``depth_mm`` option is the height of the plane they rest on.
BASE_SCENES = ("mask", "glossy", "specular_part")


def _scene_params(scene: str, depth_mm: float | None) -> dict[str, Any]:
    """The scene factory's depth argument: ``base_mm`` for :data:`BASE_SCENES`, else
    ``depth_mm``."""
    if depth_mm is None:
        return {}
    if scene in BASE_SCENES:
        return {"base_mm": depth_mm}
    return {"depth_mm": depth_mm}


def virtual_rig(
    scene: str,
    *,
    depth_mm: float | None = None,
    ambient_lux: float = 0.0,
    noise: float = 1.0,
    shot_noise: bool = True,
    aperture: str = "auto",
    gamma: float = THESIS_GAMMA,
    bit_depth: int = 8,
    ideal: bool = False,
    seed: int = 0,
    resolution: tuple[int, int] | None = None,
) -> SimulatedRig:
    """The virtual rig observing a named scene, with the light and camera options applied.

    Parameters
    ----------
    scene : str
        Scene name (:func:`hdrfringe.rig.scenes.make_scene`): white_plate, black_plate, plate,
        checkerboard, mask, glossy or specular_part.
    depth_mm : float, optional
        Plate or board depth; base height for mask, glossy and specular_part. None: the
        scene's default.
    ambient_lux : float
        Added ambient light in lux (thesis Ch. 4).
    noise : float
        Camera read noise sigma in 8-bit gray levels.
    shot_noise : bool
        Photon shot noise (the camera's full well); False: read noise only.
    aperture : {"auto", "white", "black"}
        ``white``: the default camera (a white plate peaks at 80 %); ``black``: opened for the
        black plate (thesis Sec. 5.2.2); ``auto``: black for :data:`DARK_SCENES`, else white.
    gamma : float
        Gamma pre-compensation exponent of the patterns (thesis Eq. 2.17).
    bit_depth : int
        Camera bit depth B (8, 10, 12 or 16).
    ideal : bool
        :meth:`SimulatedRig.ideal <hdrfringe.rig.simulated.SimulatedRig.ideal>`: no noise or
        blur, 16-bit camera and projector; ``noise``, ``shot_noise``, ``aperture``, ``gamma``
        and ``bit_depth`` are then ignored.
    seed : int
        Noise seed.
    resolution : tuple of int, optional
        Camera image size ``(width, height)`` in pixels over the same field of view (fewer
        pixels: faster, for examples and tests); None: the default camera's.

    Returns
    -------
    SimulatedRig

    Raises
    ------
    InputError
        An unknown scene or aperture, or a parameter the scene or camera refuses.

    References
    ----------
    Thesis Sec. 3 (the rig), Sec. 5.2.2 (aperture for the black plate).

    Examples
    --------
    >>> virtual_rig("white_plate", depth_mm=12).scene.to_manifest()
    {'name': 'white_plate', 'depth_mm': 12.0, 'reflectivity': 1.0}
    >>> virtual_rig("mask", ideal=True).projector.bit_depth
    16
    >>> bright = virtual_rig("black_plate", aperture="white").camera
    >>> virtual_rig("black_plate").camera.white_dn > bright.white_dn  # auto: opened
    True
    >>> virtual_rig("checkerboard", resolution=(160, 120)).image_shape
    (120, 160)
    """
    if aperture not in APERTURES:
        raise InputError(f"unknown aperture {aperture!r}; use auto, white or black")
    lighting = Lighting(ambient_lux=ambient_lux)
    sc = make_scene(scene, **_scene_params(scene, depth_mm))
    size = {} if resolution is None else {"width": resolution[0], "height": resolution[1]}
    if ideal:
        rig = SimulatedRig.ideal(sc, lighting=lighting, seed=seed)
        return rig.replace(camera=dataclasses.replace(rig.camera, **size)) if size else rig
    rig = SimulatedRig(sc, lighting=lighting, gamma_precompensation=gamma, seed=seed)
    cam = dataclasses.replace(
        rig.camera,
        bit_depth=bit_depth,
        read_noise_dn8=noise,
        full_well_e=rig.camera.full_well_e if shot_noise else None,
        **size,
    )
    if aperture == "black" or (aperture == "auto" and scene in DARK_SCENES):
        cam = cam.with_aperture_for(BLACK_PLATE_REFLECTIVITY)
    return rig.replace(camera=cam)
