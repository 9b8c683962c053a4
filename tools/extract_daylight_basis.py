#!/usr/bin/env python3
"""Extract the CIE daylight basis functions S0, S1, S2 (5 nm, 300-830 nm).

Provenance: colour-science (PyPI `colour-science`, BSD-3-Clause), module
`colour.colorimetry.datasets.illuminants.sds_d_illuminant_series`, table
`DATA_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES`, which reproduces CIE 15:2004
Table T.2 (via Wyszecki & Stiles 2000 and Lindbloom 2007).

Usage (writes crates/coatlab-core/data/cie_daylight_basis.csv):
    python3 -m venv /tmp/cs-venv && /tmp/cs-venv/bin/pip install colour-science
    /tmp/cs-venv/bin/python tools/extract_daylight_basis.py > crates/coatlab-core/data/cie_daylight_basis.csv
"""

import importlib.metadata

from colour.colorimetry.datasets.illuminants.sds_d_illuminant_series import (
    DATA_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES as BASIS,
)


def main() -> None:
    version = importlib.metadata.version("colour-science")
    print(
        "# CIE daylight basis functions S0, S1, S2 (CIE 15:2004 Table T.2), 5 nm."
    )
    print(
        f"# Extracted from colour-science {version} "
        "(DATA_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES) by tools/extract_daylight_basis.py."
    )
    print("wavelength_nm,S0,S1,S2")
    wavelengths = sorted(BASIS["S0"])
    assert wavelengths == sorted(BASIS["S1"]) == sorted(BASIS["S2"])
    for wl in wavelengths:
        print(f"{wl},{BASIS['S0'][wl]:g},{BASIS['S1'][wl]:g},{BASIS['S2'][wl]:g}")


if __name__ == "__main__":
    main()
