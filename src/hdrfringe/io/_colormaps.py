"""Colour tables of the map previews, stored so that a preview does not import matplotlib.

``write_preview_png`` colours a map by a 256-entry table: matplotlib's colour map sampled at
256 evenly spaced points, rounded to 8-bit RGB. Importing matplotlib (about 0.2 s of CPU,
benchmarks/README.md, cold start) to read that table cost the ``phase`` and ``measure``
commands more than writing a preview, so the tables the library's previews use are stored
here, base64 of the (256, 3) uint8 array. ``tests/test_previews.py`` checks every stored table
against matplotlib's own; after a matplotlib upgrade that changes a colour map, regenerate them
with ``python -m hdrfringe.io._colormaps`` (prints the dictionary to paste here). A colour map
not stored here is read from matplotlib on first use.
"""

from __future__ import annotations

import base64
import functools

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "LABEL_COLOURS",
    "LABEL_LUT",
    "STORED_LUTS",
    "colormap_lut",
    "label_colour_index",
    "matplotlib_lut",
]

#: base64 of each stored table: (256, 3) uint8, row k = the colour at level k / 255.
STORED_LUTS: dict[str, str] = {
    "cividis": (
        "ACJOACNPACRRACVTACVUACZWACdYAChZAChbACldACpfACphACtiACxkACxmAC1oAC5qAC5sAC9tADBvADBwADFw"
        "ADFxATJxBTNxCDNwDDRwDzVwEjVwFDZwFjdwGDdvGjhvHDlvHjpvIDpvITtuIzxuJDxuJj1uJz5uKT9uKj9tK0Bt"
        "LUFtLkFtL0JtMUNtMkNtM0RtNEVsNUVsNkZsOEdsOUhsOkhsO0lsPEpsPUpsPktsP0xsQExsQU1sQk5sQ05sRE9s"
        "RVBsRlFsR1FsSFJsSVNsSlNsS1RsTFVsTVVsTlZsT1dsUFdsUVhtUlltU1ptVFptVVttVVxtVlxtV11tWF5tWV5u"
        "Wl9uW2BuXGFuXWFuXmJuXmNvX2NvYGRvYWVvYmVvY2ZwZGdwZWhwZWhwZmlwZ2pxaGpxaWtxamxxa21ybG1ybG5y"
        "bW9ybm9zb3BzcHFzcXJ0cnJ0cnN0c3R1dHR1dXV1dnZ2d3d2d3d3eHh3eXl3enp4e3p4fHt4fXx4fnx4fn14f354"
        "gH94gX94goB5g4F5hIJ5hYJ5hoN5h4R4iIV4iYV4ioZ4i4d4jIh4jYh4jol4j4p4kIt4kYt4kox4ko14k454lI53"
        "lY93lpB3l5F3mJJ3mZJ3mpN2m5R2nJV2nZV2npZ2n5d1oJh1oZl1opl1o5p0pJt0pZx0ppx0p51zqJ5zqZ9zqqBz"
        "q6ByrKFyraJyrqNxr6RxsKVxsaVws6ZwtKdvtahvtqlvt6luuKpuuattuqxtu61tvK5sva5svq9rv7BrwLFqwbJq"
        "wrNpw7NpxLRoxbVoxrZnx7dnyLhmyblly7llzLpkzbtjzrxjz71i0L5i0b9h0sBg08Bf1MFf1cJe1sNd18Rc2cVc"
        "2sZb28da3MhZ3chY3slY38pX4MtW4cxV4s1U5M5T5c9S5tBR59FQ6NJP6dNO6tNM69RL7dVK7tZJ79dI8NhG8dlF"
        "8tpE89tC9dxB9t0/994++N88+eA6++E4/OI2/eM0/uQ0/uU1/uY2/ug4"
    ),
    "gray": (
        "AAAAAQEBAgICAwMDBAQEBQUFBgYGBwcHCAgICQkJCgoKCwsLDAwMDQ0NDg4ODw8PEBAQEREREhISExMTFBQUFRUV"
        "FhYWFxcXGBgYGRkZGhoaGxsbHBwcHR0dHh4eHx8fICAgISEhIiIiIyMjJCQkJSUlJiYmJycnKCgoKSkpKioqKysr"
        "LCwsLS0tLi4uLy8vMDAwMTExMjIyMzMzNDQ0NTU1NjY2Nzc3ODg4OTk5Ojo6Ozs7PDw8PT09Pj4+Pz8/QEBAQUFB"
        "QkJCQ0NDRERERUVFRkZGR0dHSEhISUlJSkpKS0tLTExMTU1NTk5OT09PUFBQUVFRUlJSU1NTVFRUVVVVVlZWV1dX"
        "WFhYWVlZWlpaW1tbXFxcXV1dXl5eX19fYGBgYWFhYmJiY2NjZGRkZWVlZmZmZ2dnaGhoaWlpampqa2trbGxsbW1t"
        "bm5ub29vcHBwcXFxcnJyc3NzdHR0dXV1dnZ2d3d3eHh4eXl5enp6e3t7fHx8fX19fn5+f39/gICAgYGBgoKCg4OD"
        "hISEhYWFhoaGh4eHiIiIiYmJioqKi4uLjIyMjY2Njo6Oj4+PkJCQkZGRkpKSk5OTlJSUlZWVlpaWl5eXmJiYmZmZ"
        "mpqam5ubnJycnZ2dnp6en5+foKCgoaGhoqKio6OjpKSkpaWlpqamp6enqKioqampqqqqq6urrKysra2trq6ur6+v"
        "sLCwsbGxsrKys7OztLS0tbW1tra2t7e3uLi4ubm5urq6u7u7vLy8vb29vr6+v7+/wMDAwcHBwsLCw8PDxMTExcXF"
        "xsbGx8fHyMjIycnJysrKy8vLzMzMzc3Nzs7Oz8/P0NDQ0dHR0tLS09PT1NTU1dXV1tbW19fX2NjY2dnZ2tra29vb"
        "3Nzc3d3d3t7e39/f4ODg4eHh4uLi4+Pj5OTk5eXl5ubm5+fn6Ojo6enp6urq6+vr7Ozs7e3t7u7u7+/v8PDw8fHx"
        "8vLy8/Pz9PT09fX19vb29/f3+Pj4+fn5+vr6+/v7/Pz8/f39/v7+////"
    ),
    "inferno": (
        "AAAEAQAFAQEGAQEIAgEKAgIMAgIOAwIQBAMSBAMUBQQXBgQZBwUbCAUdCQYfCgciCwckDAgmDQgpDgkrEAktEQow"
        "EgoyFAs0FQs3Fgs5GAw8GQw+GwxBHAxDHgxFHwxIIQxKIwxMJAxPJgxRKAtTKQtVKwtXLQtZLwpbMQpcMgpeNApf"
        "NglhOAliOQljOwlkPQllPglmQApnQgpoRApoRQppRwtqSQtqSgxrTAxrTQ1sTw1sUQ5sUg5tVA9tVQ9tVxBuWRBu"
        "WhFuXBJuXRJuXxNuYRNuYhRuZBVuZRVuZxZuaRZuahdubBhubRhubxlucRluchpudBpudRtudxxteBxteh1tfB1t"
        "fR5tfx5sgB9sgiBshCBrhSFrhyFriCJqiiJqjCNpjSNpjyRpkCVokiVokyZnlSZnlydmmCdmmihlmylknSlknypj"
        "oCpjoitioyxhpSxgpi1gqC5fqS5eqy9erTBdrjBcsDFbsTJaszJatDNZtjRYtzVXuTVWujZVvDdUvThTvzlSwDpR"
        "wTpQwztPxDxOxj1Nxz5MyD9LykBKy0FJzEJIzkNHz0RG0EVF0kZE00dD1EhC1UpB10s/2Ew+2U092k4821A73VE6"
        "3lI431M34FU24VY14lc041kz5Fox5Vww5l0v514u6GAt6WEr6mMq62Qp62Yo7Gcm7Wkl7mok72wj724h8G8g8XEf"
        "8XMd8nQc83Yb83gZ9HkY9XsX9X0V9n4U9oAT94IS94QQ+IUP+IcO+IkM+YsL+YwK+Y4J+pAI+pIH+pQH+5YG+5cG"
        "+5kG+5sG+50H/J8H/KEI/KMJ/KUK/KYM/KgN/KoP/KwR/K4S/LAU/LIW/LQY+7Ya+7gd+7of+7wh+74j+sAm+sIo"
        "+sQq+sYt+ccv+cky+cs1+M03+M8699E999NA9tVD9tdG9dlJ9dtM9N1P9N9T9OFW8+Na8+Vd8uZh8uhl8upp8ext"
        "8e1x8e918fF58vJ98vSC8/WG8/aK9PiO9fmS9vqW+Pua+fyd+v2h/P+k"
    ),
    "magma": (
        "AAAEAQAFAQEGAQEIAgEJAgILAgINAwMPAwMSBAQUBQQWBgUYBgUaBwYcCAceCQcgCggiCwkkDAkmDQopDgsrEAst"
        "EQwvEg0xEw00FA42FQ44Fg87GA89GRA/GhBCHBBEHRFHHhFJIBFLIRFOIhFQJBJTJRJVJxJYKRFaKhFcLBFfLRFh"
        "LxFjMRFlMxBnNBBpNhBrOBBsOQ9uOw9wPQ9xPw9yQA90Qg91RA92RRB3RxB4SRB4ShB5TBF6ThF7TxJ7URJ8UhN8"
        "VBN9VhR9VxV+WRV+WhZ+XBZ/XRd/Xxh/YBiAYhmAZBqAZRqAZxuAaByBahyBax2BbR2Bbh6BcB+Bch+BcyCBdSGB"
        "diGBeCKBeSKCeyOCfCOCfiSCgCWCgSWBgyaBhCaBhieBiCeBiSiBiymBjCmBjiqBkCqBkSuBkyuAlCyAliyAmC2A"
        "mS2Amy5/nC5/ni9/oC9/oTB+ozB+pTF+pjF9qDJ9qjN9qzN8rTR8rjR7sDV7sjV7szZ6tTZ6tzd5uDd5ujh4vDl4"
        "vTl3vzp3wDp2wjt1xDx1xTx0xz1zyD5zyj5yzD9xzUBxz0Bw0EFv0kJv00Nu1URt1kVs2EVs2UZr20dq3Ehp3klo"
        "30po4Exn4k1m405l5E9k5VBk51Jj6FNi6VRi6lZh61dg7Fhg7Vpf7lte711e8F9e8WBd8mJd8mRc82Vc9Gdc9Glc"
        "9Wtc9mxc9m5c93Bc93Jc+HRc+HZc+Xhd+Xld+Xtd+n1e+n9e+oFf+4Nf+4Vg+4dh/Ilh/Ipi/Ixj/I5k/JBl/ZJm"
        "/ZRn/ZZo/Zhp/Zpq/Ztr/p1s/p9t/qFu/qNv/qVx/qdy/qlz/qp0/qx2/q53/rB4/rJ6/rR7/rZ8/rd+/rl//ruB"
        "/r2C/r+E/sGF/sKH/sSI/saK/siM/sqN/syP/s2Q/s+S/tGU/tOV/tWX/teZ/tia/dqc/dye/d6g/eCh/eKj/eOl"
        "/eWn/eep/emq/eus/Oyu/O6w/PCy/PK0/PS2/Pa4/Pe5/Pm7/Pu9/P2/"
    ),
    "plasma": (
        "DQiHEAeIEweJFgeKGQaMGwaNHQaOIAaPIgaQJAaRJgWRKAWSKgWTLAWULgWVLwWWMQWXMwWXNQSYNwSZOASaOgSa"
        "PASbPgScPwScQQSdQwOeRAOeRgOfSAOfSQOgSwOhTAKhTgKiUAKiUQKjUwKjVQKkVgGkWAGkWQGlWwGlXAGmXgGm"
        "YAGmYQCnYwCnZACnZgCnZwCoaQCoagCobACobgCobwCocQCocgGodAGodQGodwGoeAGoegKoewKofQOofgOogASo"
        "gQSngwWnhAWnhgamhwemiAimigmliwqljQuljgykjw2kkQ6jkg+jlBCilRGhlhOhmBSgmRWfmhafnBeenRidnhmd"
        "oBqcoRuboh2aox6apR+ZpiCYpyGXqCKWqiOVqySUrCaUrSeTriiSsCmRsSqQsiuPsyyOtC6NtS+MtjCLtzGKuDKJ"
        "ujOIuzSIvDWHvTeGvjiFvzmEwDqDwTuCwjyBwz2AxD5/xUB+xkF9x0J8yEN7yUR6ykV6y0Z5zEd4zEl3zUp2zkt1"
        "z0x00E1z0U5y0k9x01Fx1FJw1VNv1VRu1lVt11Zs2Fdr2Vhq2lpq2ltp21xo3F1n3V5m3l9l3mFk32Jj4GNj4WRi"
        "4mVh4mZg42hf5Gle5Wpd5Wtd5mxc525b529a6HBZ6XFY6XJX6nRX63VW63ZV7HdU7XlT7XpS7ntR73xR735Q8H9P"
        "8IBO8YFN8YNM8oRL84VL84dK9IhJ9IlI9YtH9YxG9o1F9o9E95BE95FD95NC+JRB+JVA+Zc/+Zg++Zo++ps9+pw8"
        "+p47+586+6E5+6I4/KM4/KU3/KY2/Kg1/Kk0/asz/awz/a4y/a8x/bEw/bIv/bQv/bUu/rct/rgs/ros/rsr/r0q"
        "/r4q/sAp/cIp/cMo/cUn/cYn/cgn/com/csm/M0l/M4l/NAl/NIl+9Mk+9Uk+9ck+tgk+tok+dwk+d0l+N8l+OEl"
        "9+Il9+Ql9uYm9ugm9ekm9esn9O0n8+4n8/An8vIn8fQm8fUl8Pck8Pkh"
    ),
    "tab10": (
        "H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0H3e0"
        "H3e0H3e0H3e0H3e0/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O/38O"
        "/38O/38O/38O/38O/38O/38O/38OLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAs"
        "LKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAsLKAs1ico1ico1ico1ico1ico1ico1ico1ico1ico1ico1ico"
        "1ico1ico1ico1ico1ico1ico1ico1ico1ico1ico1ico1ico1ico1icolGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9"
        "lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9lGe9jFZLjFZLjFZLjFZL"
        "jFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZLjFZL43fC"
        "43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC43fC"
        "43fC43fC43fCf39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/f39/"
        "f39/f39/f39/f39/f39/f39/vL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0i"
        "vL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0ivL0iF77PF77PF77PF77PF77PF77PF77PF77PF77PF77PF77PF77P"
        "F77PF77PF77PF77PF77PF77PF77PF77PF77PF77PF77PF77PF77PF77P"
    ),
    "twilight": (
        "4tni4dni4Nni3tnh3dng3Nnf2tjf2Nje1tfd1Nbc0tXb0NTZzdPYy9LXyNDWxc/Vws7Uv8zTvMvRucnQtsjPs8bO"
        "sMXNrcPNqsLMp8DLpL7Kob3JnrvJnLnImbjIlrbHk7TGkrPGjrHFjK/Fia3FiKzEhanEgqfDgKXDf6XDfKLCeqDC"
        "eJ7Cd53CdZrBc5jBcZbBcZXAbpLAbZDAbI6/a42/aYq/aIi+Z4a+Z4W+ZoK9ZX+9ZH28ZHy8Y3m7Yne7YnW6YXK6"
        "YXG5YG64YGy4YGm3YGe2X2W1X2K0X2C0X1+zX1uyX1mxX1ewXlSuXlKtXk+sXk2rXkyqXkioXkamXkOlXUGjXT6h"
        "XTygXTqeXDidXDWaWzKYWzCVWi6TWiuQWSmOWCeLWCaKVyOFViGCVR9/Ux58Uhx5URp1TxlyTxlwTBdrSxZoSRVk"
        "RxRhRhReRBNaQhJXQRJWPxJRPRFOPBFLOhFJORFGNxFENhFCNhFBNBE+MxE8MhI6MRM5MBQ3MBQ3MRM3MxI3NBI4"
        "NBI4NhE5OBE5OhE6OxE7PRE8PxI9QRI9QxI+RhJASBNBShNCTRRDTxREUhVFVBVGVhVGWRZIXBdJXxdKYRhLZBlL"
        "ZxlMaRpNbBtObxxOcR1PdB5Pdh9PeSBQeyFQfiJQfyNQgyVQhSZQhydQiilQjCpQjixQkC5Qki9QlDFQljNQmDVQ"
        "mjdQnDlQnjtQoD1QoD5Qo0FQpUNQpkVQqEdQqUlQq0tQrE1RrlBRr1JRsVRSslZSs1lTtVtTtl1Ut19VuGFVuWRW"
        "umZXu2lYvGtZvW5avnBbv3JdwHVewXdfwnphwnxjw39kxIFmxYRoxYZqxodrxotux45xyJBzyJJ1yZV4yZd7ypp9"
        "ypyAy5+DzKGGzKOJzaaMzaiPzquSz62Wz66X0LKc0bSg0baj0rin07qq1L2t1b+x1sG018O42MW72Me+2cnC2svF"
        "28zI3M7L3M/N3dHR3tPT39TW39XY4Nba4Nfb4djd4djf4tng4tnh4tni"
    ),
    "viridis": (
        "RAFURAJWRQRXRQVZRgdaRghcRgpdRgteRw1gRw5hRxBjRxFkRxNlSBRnSBZoSBdpSBhqSBpsSBttSBxuSB1vSB9w"
        "SCBxSCFzSCN0SCR1SCV2SCZ3SCh4SCl5Ryp6Ryx6Ry17Ry58Ry99RjB+RjJ+RjN/RjSARTWBRTeBRTiCRDmDRDqD"
        "RDuEQz2EQz6FQj+FQkCGQkGGQUKHQUSHQEWIQEaIP0eIP0iJPkmJPkqJPkyKPU2KPU6KPE+KPFCLO1GLO1KLOlOL"
        "OlSMOVWMOVaMOFiMOFmMN1qMN1uNNlyNNl2NNV6NNV+NNGCNNGGNM2KNM2ONMmSOMmWOMWaOMWeOMWiOMGmOMGqO"
        "L2uOL2yOLm2OLm6OLm+OLXCOLXGOLHGOLHKOLHOOK3SOK3WOKnaOKneOKniOKXmOKXqOKXuOKHyOKH2OJ36OJ3+O"
        "J4COJoGOJoKOJoKOJYOOJYSOJYWOJIaOJIeOI4iOI4mOI4qNIouNIoyNIo2NIY6NIY+NIZCNIZGMIJKMIJKMIJOM"
        "H5SMH5WLH5aLH5eLH5iLH5mKH5qKHpuKHpyJHp2JH56JH5+IH6CIH6GIH6GHH6KHIKOGIKSGIaWFIaaFIqeFIqiE"
        "I6mDJKqDJauCJayCJq2BJ62BKK6AKa9/KrB/LLF+LbJ9LrN8L7R8MbV7MrZ6NLZ5Nbd5N7h4OLl3Orp2O7t1Pbx0"
        "P7xzQL1yQr5xRL9wRsBvSMFuSsFtTMJsTsNrUMRqUsVpVMVoVsZnWMdlWshkXMhjXsliYMpgY8tfZcteZ8xcac1b"
        "bM1abs5YcM9Xc9BWddBUd9FTetFRfNJQf9NOgdNNhNRLhtVJidVIi9ZGjtZFkNdDk9dBldhAmNg+m9k8ndk7oNo5"
        "oto3pds2qNs0qtwyrdwwsN0vst0ttd4ruN4put4ovd8mwN8lwt8jxeAhyOAgyuEfzeEd0OEc0uIb1eIa2OIZ2uMZ"
        "3eMY3+MY4uQY5eQZ5+QZ6uUa7OUb7+Uc8eUd9OYe9uYg+OYh++cj/ecl"
    ),
}


def matplotlib_lut(name: str) -> NDArray[np.uint8]:
    """A colour map's 256-entry 8-bit table computed by matplotlib (the reference).

    Parameters
    ----------
    name : str
        A matplotlib colour map name.

    Returns
    -------
    ndarray of uint8, shape (256, 3)
        ``rint(colormaps[name](linspace(0, 1, 256))[:, :3] * 255)``.

    Examples
    --------
    >>> matplotlib_lut("gray")[[0, 255]].tolist()
    [[0, 0, 0], [255, 255, 255]]
    """
    from matplotlib import colormaps

    rgba = colormaps[name](np.linspace(0.0, 1.0, 256))
    return np.rint(rgba[:, :3] * 255).astype(np.uint8)


#: Name of the label maps' (regions) table: not a matplotlib colour map (:data:`LABEL_COLOURS`).
LABEL_LUT = "labels"

#: Colours of label maps: matplotlib's tab10 without its gray (127, 127, 127), which reads as
#: the previews' invalid gray (128, 128, 128). A label map coloured by tab10 itself drew one
#: region in the invalid colour (issue 27).
LABEL_COLOURS: tuple[tuple[int, int, int], ...] = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207),
)  # fmt: skip


def label_colour_index(labels: NDArray[np.integer]) -> NDArray[np.float64]:
    """The values that colour positive labels 1, 2, ... by :data:`LABEL_COLOURS` in turn.

    Drawn with ``cmap=LABEL_LUT, vmin=1, vmax=len(LABEL_COLOURS)`` (a preview's linear range),
    label ``k`` gets colour ``(k - 1) % 9``: neighbouring labels differ, the tenth repeats the
    first. Labels below 1 are NaN (invalid: the previews' gray).

    Parameters
    ----------
    labels : ndarray of int
        Label map, 0 (or negative) = no label.

    Returns
    -------
    ndarray of float64
        ``(k - 1) % 9 + 1`` for a positive label ``k``, NaN elsewhere.

    Examples
    --------
    >>> label_colour_index(np.array([0, 1, 2, 9, 10])).tolist()
    [nan, 1.0, 2.0, 9.0, 1.0]
    """
    k = np.asarray(labels)
    return np.where(k > 0, (k - 1) % len(LABEL_COLOURS) + 1.0, np.nan)


def _label_lut() -> NDArray[np.uint8]:
    """256 levels in 9 equal bands, one per label colour (as tab10 is 10 bands of 25.6)."""
    band = np.arange(256) * len(LABEL_COLOURS) // 256
    return np.asarray(LABEL_COLOURS, dtype=np.uint8)[band]


@functools.cache
def colormap_lut(name: str) -> NDArray[np.uint8]:
    """The 256-entry 8-bit colour table of a preview's colour map.

    Stored tables (:data:`STORED_LUTS`) are decoded without matplotlib; any other name is
    computed by :func:`matplotlib_lut`; :data:`LABEL_LUT` is the label maps' table (no gray).
    The result is cached and read-only.

    Parameters
    ----------
    name : str
        A matplotlib colour map name (``viridis``, ``magma``, ``twilight``, ...).

    Returns
    -------
    ndarray of uint8, shape (256, 3)
        Row k is the colour of level k / 255.

    Examples
    --------
    >>> lut = colormap_lut("viridis")
    >>> lut.shape, lut.dtype, lut[0].tolist()
    ((256, 3), dtype('uint8'), [68, 1, 84])
    """
    text = STORED_LUTS.get(name)
    if name == LABEL_LUT:
        lut = _label_lut()
    elif text is None:
        lut = matplotlib_lut(name)
    else:
        lut = np.frombuffer(base64.b64decode(text), dtype=np.uint8).reshape(256, 3).copy()
    lut.flags.writeable = False
    return lut


#: The colour maps stored (those the library's previews use, and two common others).
_STORED_NAMES = ("cividis", "gray", "inferno", "magma", "plasma", "tab10", "twilight", "viridis")


def _main() -> None:
    """Print :data:`STORED_LUTS` as computed by the installed matplotlib."""
    print("STORED_LUTS: dict[str, str] = {")
    for name in _STORED_NAMES:
        text = base64.b64encode(matplotlib_lut(name).tobytes()).decode("ascii")
        print(f'    "{name}": (')
        for i in range(0, len(text), 88):
            print(f'        "{text[i : i + 88]}"')
        print("    ),")
    print("}")


if __name__ == "__main__":
    _main()
