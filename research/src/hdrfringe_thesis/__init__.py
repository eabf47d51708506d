"""Reproduction of the thesis's experiments: resumable parameter sweeps on dask.distributed
(:mod:`hdrfringe_thesis.engine`) and the experiments that run on them.

* :mod:`~hdrfringe_thesis.engine`: the sweep engine (grids, Zarr stores, resumption).
* :mod:`~hdrfringe_thesis.ch4`: the Ch. 4 measurements and simulations on the virtual rig.
* :mod:`~hdrfringe_thesis.adaptive`: the Ch. 5 (LPA) and Ch. 6 (DPA) experiments.
* :mod:`~hdrfringe_thesis.ch4_report`, :mod:`~hdrfringe_thesis.adaptive_report`: tables
  beside the thesis's, and figures.
* :mod:`~hdrfringe_thesis.runner`: ``hdrfringe reproduce``, a folder of sweeps and a report.

The package itself exports nothing; import from the modules.
"""

__all__: list[str] = []
