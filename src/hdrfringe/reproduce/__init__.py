"""Reproduction of the thesis's experiments: resumable parameter sweeps on dask.distributed
(:mod:`hdrfringe.reproduce.engine`) and the experiments that run on them."""
