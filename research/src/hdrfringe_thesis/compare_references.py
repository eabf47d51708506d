"""The thesis's numbers beside ours in ``hdrfringe compare`` (Tables 5.1, 5.2, 6.1, 6.2).

The product's comparison (:mod:`hdrfringe.tasks.compare`) imports nothing of this package:
it finds :func:`thesis_rows` through the entry-point group
:data:`hdrfringe.tasks.compare.REFERENCE_GROUP` (``research/pyproject.toml``), so its table
shows the thesis's columns when this package is installed and leaves them empty otherwise.

Examples
--------
>>> rows = thesis_rows()
>>> rows["lpa-15"]["checkerboard"].source
'Table 5.2 (pitch 8)'
>>> sorted(rows["uniform"])
['checkerboard', 'plate']
"""

from __future__ import annotations

from collections.abc import Mapping

from hdrfringe.tasks.compare import ThesisRow
from hdrfringe_thesis.adaptive_report import (
    THESIS_TABLE_5_1,
    THESIS_TABLE_5_2,
    THESIS_TABLE_6_1,
    THESIS_TABLE_6_2,
)

__all__ = ["thesis_rows"]


def _t52(key: str) -> ThesisRow:
    sets, rmse, std = THESIS_TABLE_5_2[key]
    return ThesisRow("Table 5.2 (pitch 8)", sets, None, std, rmse)


def _t6(table: Mapping[str, tuple[float, ...]], name: str, key: str) -> ThesisRow:
    sets, bias, std, rmse = table[key]
    return ThesisRow(f"{name} (mean over pitch 6-20)", sets, bias, std, rmse)


def _t51(column: int) -> ThesisRow:
    rmse = THESIS_TABLE_5_1["sinusoidal-3"][column]
    return ThesisRow("Table 5.1 (3-step, pitch 6)", None, None, None, rmse)


def thesis_rows() -> dict[str, dict[str, ThesisRow]]:
    """The thesis's numbers for the rows of :data:`hdrfringe.tasks.compare.METHODS`.

    Returns
    -------
    dict
        Method name -> thesis scene (``"checkerboard"``: Table 5.2 and 6.2; ``"plate"``: the
        white plate under 600 lx, Tables 5.1 and 6.1) -> :class:`~hdrfringe.tasks.compare.
        ThesisRow`; a method or scene the thesis has no number for is absent.

    Examples
    --------
    >>> thesis_rows()["dpa"]["plate"].source
    'Table 6.1 (mean over pitch 6-20)'
    """
    return {
        "conventional": {"plate": _t51(1)},
        "uniform": {"checkerboard": _t52("uniform"), "plate": _t51(2)},
        "lpa-1": {"checkerboard": _t52("lpa-1")},
        "lpa-5": {"checkerboard": _t52("lpa-5"), "plate": _t51(0)},
        "lpa-15": {
            "checkerboard": _t52("lpa-15"),
            "plate": _t6(THESIS_TABLE_6_1, "Table 6.1", "lpa-15"),
        },
        "dpa": {
            "checkerboard": _t6(THESIS_TABLE_6_2, "Table 6.2", "dpa-10"),
            "plate": _t6(THESIS_TABLE_6_1, "Table 6.1", "dpa-10"),
        },
    }
