"""Write ``pppack_chapter14.json``: what de Boor's own programs print for examples 3 and 4 of
chapter XIV of *A Practical Guide to Splines* (least squares by ``L2MAIN``), the reference of
``tests/test_pppack.py``.

Not run by the tests (it needs gfortran and PPPACK's sources): run it again to check the file.
Give it a folder with PPPACK's Fortran 77 files from netlib (https://www.netlib.org/pppack/:
``l2main.f l2appr.f l2err.f l2knts.f bsplvb.f bsplpp.f ppvalu.f interv.f bchfac.f bchslv.f
setdatex3.f setdatex4.f newnot.f newnotfake.f titand.f xivex3.dat xivex4.dat``)::

    python tests/data/pppack_chapter14.py PPPACK_FOLDER

Each example is built twice with gfortran: as published (single precision) and in double
precision (``-fdefault-real-8``); ``-fdec`` lets the 1978 character constants compile.
Example 3: 65 values of exp(x) on [0, 3] truncated to two decimals, order 3, uniform breaks,
1 to 20 intervals (the fake NEWNOT). Example 4: the titanium heat data, order 5, de Boor's 7
interior breaks, then four NEWNOT passes adding 0, 2, 2, 2 breaks.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

COMMON = ("l2main.f", "l2appr.f", "l2err.f", "l2knts.f", "bsplvb.f", "bsplpp.f", "ppvalu.f",
          "interv.f", "bchfac.f", "bchslv.f")
EXAMPLES = {"ex3": (("setdatex3.f", "newnotfake.f"), "xivex3.dat"),
            "ex4": (("setdatex4.f", "newnot.f", "titand.f"), "xivex4.dat")}
PRECISIONS = {"single": (), "double": ("-fdefault-real-8", "-fdefault-double-8")}
BLOCK = re.compile(r"on\s+(\d+) intervals\. breakpoints -\n(.*?)\n\s*\n.*?"
                   r"least square error =\s*(\S+)\s*\n\s*average error\s*=\s*(\S+)\s*\n"
                   r"\s*maximum error\s*=\s*(\S+)", re.S)


def printed(text: str) -> list[dict]:
    """Each approximation L2MAIN prints: its intervals, interior breaks and three errors."""
    return [{"intervals": int(count), "interior_breaks": [float(b) for b in breaks.split()],
             "least_square_error": float(l2), "average_error": float(l1),
             "maximum_error": float(largest)}
            for count, breaks, l2, l1, largest in BLOCK.findall(text)]


def main(sources: Path) -> None:
    out: dict = {"source": "de Boor's PPPACK from netlib (L2MAIN, chapter XIV examples 3 and "
                           "4), built with gfortran -fdec; single: as published, double: "
                           "-fdefault-real-8; written by tests/data/pppack_chapter14.py"}
    with tempfile.TemporaryDirectory() as work:
        for example, (own, data) in EXAMPLES.items():
            for precision, flags in PRECISIONS.items():
                program = Path(work) / f"{example}_{precision}"
                files = [str(sources / name) for name in (*COMMON, *own)]
                subprocess.run(["gfortran", "-fdec", "-w", *flags, "-o", str(program), *files],
                               check=True)
                text = subprocess.run([str(program)], stdin=(sources / data).open(),
                                      capture_output=True, text=True, check=True).stdout
                out[f"{example}_{precision}"] = printed(text)
    target = Path(__file__).with_suffix(".json")
    target.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {target}")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
