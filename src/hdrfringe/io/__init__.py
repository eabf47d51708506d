"""Input and output: capture folders, result folders, map files.

One module per kind of file; import from the module, e.g.
``from hdrfringe.io.results import write_map_tiff``:

* :mod:`~hdrfringe.io.captures`: capture folders (docs/capture_format.md) to and from
  :class:`~hdrfringe.core.captures.Captures`.
* :mod:`~hdrfringe.io.pattern_folder`: pattern folders for a real projector.
* :mod:`~hdrfringe.io.calibration_file`: phase-to-height calibration files.
* :mod:`~hdrfringe.io.results`: result folders written atomically, float32 TIFF maps, PNG
  previews.
* :mod:`~hdrfringe.io.phase_maps`: the phase stage's maps in a result folder.
* :mod:`~hdrfringe.io.point_cloud`: PLY point clouds.
* :mod:`~hdrfringe.io.plots`: the library's figures as PNG files.

File formats only: the workflows that read and write them for a command (a measurement's
outputs, calibrating from folders, simulating) are :mod:`hdrfringe.tasks`. The package itself
exports nothing, so importing it does not import the readers and writers
(nor their third-party libraries).
"""

__all__: list[str] = []
