"""The thesis's numbers beside ours in ``hdrfringe compare``: this package gives them to the
product through the entry-point group ``hdrfringe.compare_references`` (research/pyproject.toml),
taken from the thesis's tables as :mod:`hdrfringe_thesis.adaptive_report` holds them."""

from __future__ import annotations

from hdrfringe.tasks import compare as cmp
from hdrfringe_thesis.adaptive_report import (
    THESIS_TABLE_5_1,
    THESIS_TABLE_5_2,
    THESIS_TABLE_6_1,
    THESIS_TABLE_6_2,
)
from hdrfringe_thesis.compare_references import thesis_rows


def test_the_product_finds_them_through_the_entry_point() -> None:
    assert cmp.thesis_references() == thesis_rows()


def test_each_row_is_its_table_entry() -> None:
    rows = thesis_rows()
    assert set(rows) <= {m.name for m in cmp.METHODS}
    assert all(set(scenes) <= {"checkerboard", "plate"} for scenes in rows.values())
    # Table 5.2 (sets, RMSE, std), checkerboard at pitch 8
    sets, rmse, std = THESIS_TABLE_5_2["lpa-15"]
    assert rows["lpa-15"]["checkerboard"] == cmp.ThesisRow(
        "Table 5.2 (pitch 8)", sets, None, std, rmse
    )
    # Tables 6.1 / 6.2 (sets, bias, std, RMSE): DPA 10 % on the plate and the checkerboard
    for scene, table in (("plate", THESIS_TABLE_6_1), ("checkerboard", THESIS_TABLE_6_2)):
        row = rows["dpa"][scene]
        assert (row.sets, row.bias_mm, row.std_mm, row.rmse_mm) == table["dpa-10"]
    # Table 5.1 (RMSE of the 3-step set at pitch 6: LPA S=5, conventional, uniform)
    assert [rows[m]["plate"].rmse_mm for m in ("lpa-5", "conventional", "uniform")] == list(
        THESIS_TABLE_5_1["sinusoidal-3"]
    )
