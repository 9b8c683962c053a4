#!/usr/bin/env python3
"""Extract the published CIE D50 table (5 nm, 300-780 nm) as a test fixture.

Provenance: colour-science (PyPI `colour-science`, BSD-3-Clause),
`colour.SDS_ILLUMINANTS["D50"]`, the CIE standard illuminant D50 table (3 decimals,
ISO 11664-2 / CIE S 014-2). Used only to check coatlab's D50, which coatlab derives
itself from the daylight basis (see tools/extract_daylight_basis.py).

Usage:
    /tmp/cs-venv/bin/python tools/extract_d50_table.py > crates/coatlab-core/tests/data/cie_d50_table.csv
"""

import importlib.metadata

import colour


def main() -> None:
    version = importlib.metadata.version("colour-science")
    d50 = colour.SDS_ILLUMINANTS["D50"]
    print(f"# CIE D50 as tabulated in colour-science {version} (SDS_ILLUMINANTS['D50']).")
    print("wavelength_nm,D50")
    for wl, value in zip(d50.wavelengths, d50.values):
        print(f"{wl:g},{value:g}")


if __name__ == "__main__":
    main()
