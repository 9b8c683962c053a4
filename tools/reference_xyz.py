#!/usr/bin/env python3
"""Independent reference XYZ/Lab for tests/cli_colour.rs (`coatlab color`).

Computes, with colour-science (PyPI `colour-science`), the tristimulus values of a
test spectrum tabulated at 5 nm over 380-780 nm, by plain summation
(`method="Integration"`), for D65 / CIE 1964 10° and A / CIE 1931 2°.
The spectrum is printed too, at 4 decimals, exactly as the test embeds it.

Usage: /tmp/cs-venv/bin/python tools/reference_xyz.py
"""

import math

import colour
import numpy as np


def reflectance(wavelength_nm: float) -> float:
    return round(0.3 + 0.2 * math.sin((wavelength_nm - 380.0) / 50.0), 4)


def main() -> None:
    wavelengths = np.arange(380, 781, 5)
    values = [reflectance(w) for w in wavelengths]
    print("spectrum:", ",".join(f"{v:g}" for v in values))
    sd = colour.SpectralDistribution(dict(zip(wavelengths, values)))
    shape = colour.SpectralShape(380, 780, 5)
    for ill, obs in (("D65", "CIE 1964 10 Degree Standard Observer"), ("A", "CIE 1931 2 Degree Standard Observer")):
        cmfs = colour.MSDS_CMFS[obs].copy().align(shape)
        illuminant = colour.SDS_ILLUMINANTS[ill].copy().align(shape)
        xyz = colour.sd_to_XYZ(sd, cmfs, illuminant, method="Integration")
        white = colour.sd_to_XYZ(colour.sd_ones(shape), cmfs, illuminant, method="Integration")
        lab = colour.XYZ_to_Lab(xyz / 100, colour.XYZ_to_xy(white / 100))
        print(ill, obs, "XYZ", list(xyz), "Lab", list(lab), "white", list(white))


if __name__ == "__main__":
    main()
