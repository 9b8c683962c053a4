#!/usr/bin/env python3
"""Independent reference readings of the virtual instruments (spec section 7).

For each design listed in DESIGNS, from the design file and the CIE tables alone:

- the multi-angle spectrophotometer: collimated illumination at 45 degrees, detectors
  in the plane of incidence at aspecular 15, 25, 45, 75, 110 degrees measured from the
  specular direction toward the illuminator, reflectance factor pi*f(wi, wo) (spec
  sections 4 and 7; the spec gives this instrument no aperture, so each reading is the
  BRDF at one pair of directions), CIELAB under D65 for the CIE 1964 10-degree observer
  (spec section 6: plain 5 nm summation over 380-780 nm);
- the glossmeter (spec 4.3): ISO 2813 geometries 20, 60, 85 degrees, source aperture
  0.75 x 2.5 degrees, receptor apertures 1.80 x 3.6, 4.4 x 11.7, 4.0 x 6.0 degrees
  (in the plane of incidence x across it), 100 GU = polished black glass of n = 1.567;
  the design's gloss fixes the lobe exponent m through this same instrument (normalised
  lobe, n at 587.6 nm), and the reading reported is the design's specular part alone
  and specular plus body, each wavelength weighted by the CIE 1931 y-bar under D65.

Nothing here is taken from the Rust code; the shared inputs are the design TOML files
and the CIE table (crates/coatlab-core/data/cie_tables.csv). The formulas are written
again from the spec:

- Fresnel (spec 3) in the cosine form; the body term (spec 4.1) in closed form with
  the coat integral C(n, tau) from tools/c_integral_reference.py (mpmath tanh-sinh in
  the inside angle, 40 digits, checked there against closed forms);
- the lobe normalisation N(mu, m) = Int_{H+} max(0, wo.wr)^m mu_o dw_o (spec 4.2)
  with the azimuthal integral about the mirror direction in closed form and SciPy's
  adaptive QUADPACK over u = -m ln(cos alpha), split where the lobe's cone first
  touches the horizon; checked against 2 pi/(m + 2) at normal incidence and against an
  mpmath quadrature;
- the glossmeter's receptor integrals by composite Gauss-Legendre (24 points a panel)
  in the receptor's focal-plane coordinates, on panels graded about the lobe's peak,
  vectorised (used for the root-find of m and for every reading); checked, for a
  2 x 2 subset of the source rays, against nested adaptive QUADPACK in the spherical
  angles (theta_o, phi_o) of the outgoing direction, where the rectangular field stop
  has closed-form limits in phi for each theta and the paper lobe's kinks
  (theta_o = theta_r, phi_o = phi_r) are straight lines, split at the field stop's
  corners and edges and at the lobe's peak (the two agree to 1.4e-8 GU);
- the source aperture is integrated with a Gauss-Legendre product rule in the
  source's focal-plane (tangent) coordinates, converged: SOURCE_ORDER points a side,
  checked against SOURCE_CHECK_ORDER.

A Cauchy index is taken at each 5 nm sample's wavelength (the Rust side averages it
over the sample's bin; Delta n ~ 1e-6).

Conventions the spec leaves open, chosen as the project's instrument documents them:
apertures are rectangles in the focal planes of the instrument's lenses (a direction's
coordinates are the tangents of its angles to the optical axis), the source is uniform
over its field stop in those coordinates; the paper lobe's azimuth difference is 0
when the outgoing or the mirror direction is the normal (the limit along the plane of
incidence from the specular side); the mirror exponent (gloss at or above what
m = 1e9 reads) puts all of each source ray's specular flux into the receptor.

Output: one row per reading, with a quadrature uncertainty estimated from the
cross-checks above (the largest difference between the two receptor quadratures, the
two source orders and the two lobe normalisations), and the reading's derivative with
respect to ln m (the Rust test allows for the product's own m through it).

Usage (writes crates/coatlab-core/tests/data/instrument_reference.csv, about 15
minutes on one core; the output is deterministic but for the date):
    python3 -m venv /tmp/instr-venv && /tmp/instr-venv/bin/pip install -r tools/requirements.txt
    /tmp/instr-venv/bin/python tools/instrument_reference.py \\
        > crates/coatlab-core/tests/data/instrument_reference.csv

Progress goes to stderr.
"""

import csv
import datetime
import importlib.metadata
import math
import os
import sys
import time
import tomllib

import numpy as np
from mpmath import mp, mpf
from scipy import integrate, optimize

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from c_integral_reference import c_scaled  # noqa: E402  (mpmath, 40 digits)

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
CIE_CSV = os.path.join(ROOT, "crates/coatlab-core/data/cie_tables.csv")

# (name in the CSV, design file relative to the repository root)
DESIGNS = [
    ("signal-red", "assets/presets/signal-red.toml"),
    ("deep-blue", "assets/presets/deep-blue.toml"),
    ("satin-grey", "assets/presets/satin-grey.toml"),
    ("jet-black", "assets/presets/jet-black.toml"),
    ("hand-written", "crates/coatlab-core/tests/data/designs/hand-written.toml"),
    ("low-gloss", "crates/coatlab-core/tests/data/designs/low-gloss.toml"),
]

WAVELENGTHS = np.arange(380.0, 780.0 + 0.5, 5.0)
ILLUMINATION_DEG = 45.0
ASPECULAR_DEG = [15.0, 25.0, 45.0, 75.0, 110.0]
GLOSS_WAVELENGTH_NM = 587.6
BLACK_GLASS_N = 1.567
MAX_EXPONENT = 1e9
SOURCE_APERTURE_DEG = (0.75, 2.5)
RECEPTOR_APERTURE_DEG = {20: (1.80, 3.6), 60: (4.4, 11.7), 85: (4.0, 6.0)}
SOURCE_ORDER = 8
SOURCE_CHECK_ORDER = SOURCE_ORDER + 4
QUAD_REL = 1e-11


# ----------------------------------------------------------------------------------
# Inputs


def read_cie():
    with open(CIE_CSV, newline="") as f:
        rows = [r for r in csv.DictReader(f)]
    table = {float(r["wavelength_nm"]): r for r in rows}
    col = lambda name: np.array([float(table[w][name]) for w in WAVELENGTHS])  # noqa: E731
    return {k: col(k) for k in ("x2", "y2", "z2", "x10", "y10", "z10", "D65")}


def linear_clamped(xs, ys, x):
    return float(np.interp(x, xs, ys, left=ys[0], right=ys[-1]))


class Design:
    def __init__(self, path):
        with open(os.path.join(ROOT, path), "rb") as f:
            d = tomllib.load(f)
        self.name = d["name"]
        alb = d["pigment"]["albedo"]
        self.rho = np.array([linear_clamped(alb["wavelength_nm"], alb["value"], w) for w in WAVELENGTHS])
        coat = d["clear_coat"]
        self.h = float(coat["thickness_um"])
        ri = coat["refractive_index"]
        if "cauchy" in ri:
            a, b = ri["cauchy"]["a"], ri["cauchy"]["b_um2"]
            self.index_at = lambda w: a + b / (w * 1e-3) ** 2
        else:
            t = ri["table"]
            self.index_at = lambda w: linear_clamped(t["wavelength_nm"], t["value"], w)
        ab = coat["absorption_per_um"]
        if "constant" in ab:
            k_at = lambda w: float(ab["constant"])  # noqa: E731
        else:
            t = ab["table"]
            k_at = lambda w: linear_clamped(t["wavelength_nm"], t["value"], w)  # noqa: E731
        self.n = np.array([self.index_at(w) for w in WAVELENGTHS])
        self.tau = np.array([k_at(w) * self.h for w in WAVELENGTHS])
        self.n_gloss = self.index_at(GLOSS_WAVELENGTH_NM)
        g = d["gloss"]
        self.gu = float(g["gu"])
        self.geometry = int(g["geometry_deg"])
        self.lobe = g["lobe"]


# ----------------------------------------------------------------------------------
# Physics (spec 3, 4.1, 4.2)


def fresnel(mu, n):
    """Unpolarised Fresnel reflectance from air at outside cosine mu (cosine form)."""
    mu = min(max(mu, 0.0), 1.0)
    if n == 1.0:
        return 0.0
    mu_t = math.sqrt(1.0 - (1.0 - mu * mu) / (n * n))
    rs = (mu - n * mu_t) / (mu + n * mu_t)
    rp = (n * mu - mu_t) / (n * mu + mu_t)
    return 0.5 * (rs * rs + rp * rp)


def inside_cosine(mu, n):
    return math.sqrt(1.0 - (1.0 - mu * mu) / (n * n))


C_CACHE = {}


def coat_integral(n, tau):
    key = (n, tau)
    if key not in C_CACHE:
        value, _ = c_scaled(mpf(n), mpf(tau))
        C_CACHE[key] = float(value * mp.exp(-2 * mpf(tau)))
    return C_CACHE[key]


def body_brdf(rho, n, tau, c, mu_i, mu_o):
    """f_body of spec 4.1, 1/sr."""
    if mu_i <= 0.0 or mu_o <= 0.0:
        return 0.0
    ti = (1.0 - fresnel(mu_i, n)) * math.exp(-tau / inside_cosine(mu_i, n))
    to = (1.0 - fresnel(mu_o, n)) * math.exp(-tau / inside_cosine(mu_o, n))
    return rho * ti * to / (n * n * (math.pi - rho * c))


def azimuthal_closed_form(t, mu_r, s_r):
    """Int_0^{2pi} max(0, mu_o) d(beta) on the cone at cos(alpha) = t about the mirror
    direction: mu_o = t mu_r + sqrt(1 - t^2) s_r cos(beta)."""
    a = t * mu_r
    b = math.sqrt(max(0.0, 1.0 - t * t)) * s_r
    if a >= b:
        return 2.0 * math.pi * a
    return 2.0 * a * math.acos(-a / b) + 2.0 * math.sqrt(b * b - a * a)


def lobe_normalisation(mu_r, m):
    """N(mu, m) = Int_{H+} max(0, wo.wr)^m mu_o dw_o, wr at polar cosine mu_r."""
    s_r = math.sqrt(max(0.0, 1.0 - mu_r * mu_r))
    opts = dict(epsabs=0.0, epsrel=1e-13, limit=400)
    if m == 0.0:
        pts = [s_r] if 0.0 < s_r < 1.0 else None
        return integrate.quad(lambda t: azimuthal_closed_form(t, mu_r, s_r), 0.0, 1.0, points=pts, **opts)[0]

    # t = cos(alpha) = exp(-u/m): t^m dt = e^{-u} t du / m.
    def g(u):
        t = math.exp(-u / m)
        return math.exp(-u) * azimuthal_closed_form(t, mu_r, s_r) * t / m

    end = 80.0  # e^{-80} of the peak
    u0 = -m * math.log(s_r) if s_r > 0.0 else math.inf
    total = 0.0
    for lo, hi in ([(0.0, u0), (u0, u0 + end)] if u0 < end else [(0.0, end)]):
        total += integrate.quad(g, lo, hi, **opts)[0]
    return total


def lobe_normalisation_mpmath(mu_r, m):
    """The same integral in t with mpmath (a check of lobe_normalisation)."""
    mu_r, m = mpf(mu_r), mpf(m)
    s_r = mp.sqrt(1 - mu_r * mu_r)

    def a_of(t):
        a = t * mu_r
        b = mp.sqrt(max(0, 1 - t * t)) * s_r
        if a >= b:
            return 2 * mp.pi * a
        return 2 * a * mp.acos(-a / b) + 2 * mp.sqrt(b * b - a * a)

    pts = [mpf(0)] + ([s_r] if 0 < s_r < 1 else [])
    pts += [1 - mpf(4) ** k / (m + 1) for k in range(-2, 12) if 0 < 1 - mpf(4) ** k / (m + 1) < 1]
    pts = sorted(set(pts)) + [mpf(1)]
    return float(mp.quad(lambda t: t**m * a_of(t), pts))


def mirror(w):
    return (-w[0], -w[1], w[2])


def normal_lobe_value(wi, wo, m):
    """max(0, wo.wr)^m with 1 - cos from the chord (sharp lobes)."""
    r = mirror(wi)
    d = 0.5 * ((wo[0] - r[0]) ** 2 + (wo[1] - r[1]) ** 2 + (wo[2] - r[2]) ** 2)
    if d >= 1.0:
        return 0.0
    if m == 0.0:
        return 1.0
    return math.exp(m * math.log1p(-d))


def polar_azimuth(w):
    return math.atan2(math.hypot(w[0], w[1]), w[2]), math.atan2(w[1], w[0])


def paper_lobe_angles(theta_o, phi_o, theta_r, phi_r, m):
    """cos((|theta_o - theta_r| + |dphi|)/2)^m clamped at 0 (spec 4.2, eq. 25')."""
    if theta_o == 0.0 or theta_r == 0.0:
        dphi = 0.0
    else:
        dphi = abs(math.remainder(phi_o - phi_r, 2.0 * math.pi))
    angle = 0.5 * (abs(theta_o - theta_r) + dphi)
    c = math.cos(angle)
    if c <= 0.0:
        return 0.0
    if m == 0.0:
        return 1.0
    return math.exp(m * math.log1p(-2.0 * math.sin(0.5 * angle) ** 2))


# ----------------------------------------------------------------------------------
# Colour (spec 6)


class Colour:
    def __init__(self, cie):
        s = cie["D65"]
        k = 100.0 / np.sum(s * cie["y10"])
        self.wx, self.wy, self.wz = k * s * cie["x10"], k * s * cie["y10"], k * s * cie["z10"]
        self.white = (self.wx.sum(), self.wy.sum(), self.wz.sum())
        lum = s * cie["y2"]
        self.luminance = lum / lum.sum()

    def lab(self, r):
        xyz = (float(self.wx @ r), float(self.wy @ r), float(self.wz @ r))

        def f(t):
            eps, kappa = 216.0 / 24389.0, 24389.0 / 27.0
            return t ** (1.0 / 3.0) if t > eps else (kappa * t + 16.0) / 116.0

        fx, fy, fz = (f(v / w) for v, w in zip(xyz, self.white))
        return 116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)


# ----------------------------------------------------------------------------------
# The glossmeter (spec 4.3)


def unit(v):
    n = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return (v[0] / n, v[1] / n, v[2] / n)


def source_rays(geometry_deg, order):
    """Directions toward the source (the BRDF's wi) and weights summing to 1."""
    t = math.radians(geometry_deg)
    axis, across = (-math.sin(t), 0.0, math.cos(t)), (math.cos(t), 0.0, math.sin(t))
    hx = math.tan(math.radians(0.5 * SOURCE_APERTURE_DEG[0]))
    hy = math.tan(math.radians(0.5 * SOURCE_APERTURE_DEG[1]))
    nodes, weights = np.polynomial.legendre.leggauss(order)
    rays = []
    for x, wx in zip(nodes * hx, weights):
        for y, wy in zip(nodes * hy, weights):
            rays.append((unit((axis[0] + x * across[0], y, axis[2] + x * across[2])), wx * wy / 4.0))
    return rays


class Receptor:
    """The receptor's field stop, integrated over in the outgoing direction's own
    polar and azimuthal angles."""

    def __init__(self, geometry_deg):
        self.tg = math.radians(geometry_deg)
        ax, ay = RECEPTOR_APERTURE_DEG[geometry_deg]
        self.hx = math.tan(math.radians(0.5 * ax))
        self.hy = math.tan(math.radians(0.5 * ay))
        tg = self.tg
        self.axis = (math.sin(tg), 0.0, math.cos(tg))
        self.ex = (math.cos(tg), 0.0, -math.sin(tg))
        corner = lambda x, y: polar_azimuth(unit((self.axis[0] + x * self.ex[0], y, self.axis[2] + x * self.ex[2])))  # noqa: E731
        self.theta_min = tg - math.atan(self.hx)
        self.theta_edge = tg + math.atan(self.hx)  # where the far edge leaves the plane
        self.theta_corner_near = corner(-self.hx, self.hy)[0]
        self.theta_max = corner(self.hx, self.hy)[0]
        self.tan_lo = math.tan(tg - math.atan(self.hx))
        self.tan_hi = math.tan(tg + math.atan(self.hx))
        self.r_y = math.sqrt(1.0 + (self.hy * math.sin(tg)) ** 2)
        self.delta_y = math.atan(self.hy * math.sin(tg))

    def phi_ranges(self, theta):
        """The azimuths (as [lo, hi] intervals) of directions at polar angle theta that
        pass the field stop: x <= hx iff cos(phi) <= cot(theta) tan(tg + atan hx),
        x >= -hx iff cos(phi) >= cot(theta) tan(tg - atan hx), |y| <= hy iff
        |phi| <= delta + asin(hy cot(theta) cos(tg) / R)."""
        cot = math.cos(theta) / math.sin(theta)
        c1 = cot * self.tan_hi
        c2 = cot * self.tan_lo
        if c2 > 1.0:
            return []
        phi_lo = math.acos(c1) if c1 < 1.0 else 0.0
        phi_x = math.acos(max(c2, -1.0))
        arg = self.hy * cot * math.cos(self.tg) / self.r_y
        phi_y = self.delta_y + math.asin(min(arg, 1.0))
        phi_hi = min(phi_x, phi_y)
        if phi_hi <= phi_lo:
            return []
        if phi_lo == 0.0:
            return [(-phi_hi, phi_hi)]
        return [(-phi_hi, -phi_lo), (phi_lo, phi_hi)]

    def integral_polar(self, g):
        """Int over the field stop of g(theta) cos(theta) dw for g independent of the
        azimuth: the inner integral is g times the length of the azimuth ranges."""
        opts = dict(epsabs=0.0, epsrel=QUAD_REL, limit=500)
        breaks_t = sorted({self.theta_min, self.theta_edge, self.theta_corner_near, self.theta_max})

        def inner(theta):
            span = sum(hi - lo for lo, hi in self.phi_ranges(theta))
            return g(theta) * span * math.cos(theta) * math.sin(theta)

        return sum(integrate.quad(inner, a, b, **opts)[0] for a, b in zip(breaks_t, breaks_t[1:]) if b > a)

    def integral(self, g, peak=None, width=None):
        """Int over the field stop of g(theta, phi) cos(theta) dw, by nested adaptive
        quadrature in (theta, phi); `peak` = (theta, phi) of a sharp feature of g of
        angular scale `width`, where the panels are split."""
        opts = dict(epsabs=0.0, epsrel=QUAD_REL, limit=500)
        breaks_t = [self.theta_min, self.theta_edge, self.theta_corner_near, self.theta_max]
        breaks_p = []
        if peak is not None:
            for s in (0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 9.0):
                breaks_t += [peak[0] - s * width, peak[0] + s * width]
                breaks_p += [peak[1] - s * width / math.sin(peak[0]), peak[1] + s * width / math.sin(peak[0])]
        breaks_t = sorted(t for t in set(breaks_t) if self.theta_min <= t <= self.theta_max)

        def inner(theta):
            total = 0.0
            for lo, hi in self.phi_ranges(theta):
                pts = sorted(p for p in set(breaks_p) if lo < p < hi)
                cuts = [lo] + pts + [hi]
                for a, b in zip(cuts, cuts[1:]):
                    total += integrate.quad(lambda phi: g(theta, phi), a, b, **opts)[0]
            return total * math.cos(theta) * math.sin(theta)

        total = 0.0
        for a, b in zip(breaks_t, breaks_t[1:]):
            if b > a:
                total += integrate.quad(inner, a, b, **opts)[0]
        return total

    def integral_focal_plane(self, g_dir, peak_dir, width, order=24):
        """The same integral in the receptor's focal-plane coordinates (x, y) by
        composite Gauss-Legendre on panels graded about the peak (vectorised; g_dir
        takes arrays of unit vectors, shape (3, ...))."""
        a, ex = np.array(self.axis), np.array(self.ex)
        ey = np.array([0.0, 1.0, 0.0])
        along = float(np.dot(peak_dir, a))
        px, py = float(np.dot(peak_dir, ex)) / along, float(np.dot(peak_dir, ey)) / along

        def cuts(c, half):
            pts = {-half, half}
            for s in (0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 9.0, 14.0):
                pts |= {c - s * width, c + s * width}
            return np.array(sorted(p for p in pts if -half <= p <= half))

        nodes, weights = np.polynomial.legendre.leggauss(order)

        def rule(c):
            xs, ws = [], []
            for lo, hi in zip(c[:-1], c[1:]):
                xs.append(0.5 * (hi - lo) * nodes + 0.5 * (hi + lo))
                ws.append(0.5 * (hi - lo) * weights)
            return np.concatenate(xs), np.concatenate(ws)

        x, wx = rule(cuts(px, self.hx))
        y, wy = rule(cuts(py, self.hy))
        X, Y = np.meshgrid(x, y, indexing="ij")
        v = a[:, None, None] + ex[:, None, None] * X + ey[:, None, None] * Y
        len2 = (v * v).sum(axis=0)
        wo = v / np.sqrt(len2)
        jac = len2 ** -1.5
        return float((np.outer(wx, wy) * jac * np.maximum(wo[2], 0.0) * g_dir(wo)).sum())


def mirror_flux(rays, n):
    return sum(w * fresnel(wi[2], n) for wi, w in rays)


def spec_fraction_focal(receptor, wi, m):
    """Fraction of a normalised lobe's flux from wi that reaches the receptor (fast)."""
    r = np.array(mirror(wi))
    width = 1.0 / math.sqrt(m + 1.0)

    def g(wo):
        d = 0.5 * ((wo - r[:, None, None]) ** 2).sum(axis=0)
        with np.errstate(divide="ignore"):
            out = np.where(d < 1.0, np.exp(m * np.log1p(-np.minimum(d, 1.0))), 0.0)
        return out if m > 0.0 else np.where(d < 1.0, 1.0, 0.0)

    return receptor.integral_focal_plane(g, r, width) / lobe_normalisation(wi[2], m)


def normalised_reading_focal(geometry, n, m, rays, receptor):
    flux = sum(w * fresnel(wi[2], n) * spec_fraction_focal(receptor, wi, m) for wi, w in rays)
    return 100.0 * flux / mirror_flux(rays, BLACK_GLASS_N)


def exponent_from_gloss(design):
    """m(g): the exponent whose simulated reading at the design's geometry (normalised
    lobe, n at 587.6 nm) is the design's gloss; None for the ideal mirror."""
    geometry, n = design.geometry, design.n_gloss
    rays = source_rays(geometry, SOURCE_ORDER)
    receptor = Receptor(geometry)
    reading = lambda x: normalised_reading_focal(geometry, n, math.expm1(x), rays, receptor)  # noqa: E731
    x_max = math.log1p(MAX_EXPONENT)
    if design.gu >= reading(x_max):
        return None
    lo = reading(0.0)
    assert design.gu > lo, (design.name, design.gu, lo)
    x = optimize.brentq(lambda x: reading(x) - design.gu, 0.0, x_max, xtol=1e-13, rtol=1e-15, maxiter=200)
    return math.expm1(x)


def specular_captured(receptor, wi, m, lobe, focal):
    """Flux of the specular lobe's shape from source ray wi into the receptor, per unit
    Fresnel factor: Int_rec D mu_o dw / N for the normalised lobe, Int_rec D_paper mu_o dw
    for the paper's; 1 for the ideal mirror (its reflection stays inside the receptor)."""
    if m is None:
        return 1.0
    wr = mirror(wi)
    theta_r, phi_r = polar_azimuth(wr)
    if lobe == "normalised":
        if focal:
            return spec_fraction_focal(receptor, wi, m)

        def g(theta, phi):
            wo = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
            return normal_lobe_value(wi, wo, m)

        width = 1.0 / math.sqrt(m + 1.0)
        return receptor.integral(g, (theta_r, phi_r), width) / lobe_normalisation(wi[2], m)
    # The paper's lobe is about twice as wide as the Phong lobe of the same m.
    width = 2.0 / math.sqrt(m + 1.0)
    if focal:
        def gv(wo):
            th = np.arctan2(np.hypot(wo[0], wo[1]), wo[2])
            ph = np.arctan2(wo[1], wo[0])
            dphi = np.abs(np.remainder(ph - phi_r + np.pi, 2 * np.pi) - np.pi)
            ang = 0.5 * (np.abs(th - theta_r) + dphi)
            return np.where(np.cos(ang) > 0, np.exp(m * np.log1p(-2 * np.sin(0.5 * ang) ** 2)), 0.0)

        return receptor.integral_focal_plane(gv, np.array(wr), width)
    return receptor.integral(lambda theta, phi: paper_lobe_angles(theta, phi, theta_r, phi_r, m), (theta_r, phi_r), width)


def gloss_readings(design, colour, m, order, focal=False):
    """(specular GU, total GU) at 20, 60, 85 degrees."""
    w = colour.luminance
    c = [coat_integral(float(n), float(t)) for n, t in zip(design.n, design.tau)]
    spectral = list(zip(w, (float(v) for v in design.rho), (float(v) for v in design.n), (float(v) for v in design.tau), c))
    out = {}
    for geometry in (20, 60, 85):
        rays = source_rays(geometry, order)
        receptor = Receptor(geometry)
        glass = mirror_flux(rays, BLACK_GLASS_N)
        spec_flux = body_flux = 0.0
        for wi, weight in rays:
            r_eff = sum(wl * fresnel(wi[2], n) for wl, _, n, _, _ in spectral)
            spec_flux += weight * r_eff * specular_captured(receptor, wi, m, design.lobe, focal)

            def body_of_mu(mu_o, mu_i=wi[2]):
                return sum(wl * body_brdf(rho, n, tau, ci, mu_i, mu_o) for wl, rho, n, tau, ci in spectral)

            if focal:
                body_flux += weight * receptor.integral_focal_plane(
                    lambda wo: np.vectorize(body_of_mu)(np.clip(wo[2], 0.0, 1.0)), np.array(receptor.axis), 1.0, order=8
                )
            else:
                body_flux += weight * receptor.integral_polar(lambda theta: body_of_mu(math.cos(theta)))
        spec = 100.0 * spec_flux / glass
        body = 100.0 * body_flux / glass
        out[geometry] = (spec, spec + body)
    return out


def multi_angle(design, colour, m, normalisation=None):
    """L*, a*, b* (D65/10) at each aspecular angle."""
    normalisation = normalisation or lobe_normalisation
    t = math.radians(ILLUMINATION_DEG)
    wi = (-math.sin(t), 0.0, math.cos(t))
    c = [coat_integral(float(n), float(tau)) for n, tau in zip(design.n, design.tau)]
    theta_r, phi_r = polar_azimuth(mirror(wi))
    out = []
    for aspecular in ASPECULAR_DEG:
        d = math.radians(ILLUMINATION_DEG - aspecular)  # signed: + on the specular side
        wo = (math.sin(d), 0.0, math.cos(d))
        theta_o, phi_o = polar_azimuth(wo)
        if m is None:
            lobe = 0.0  # the mirror's delta never reaches a detector off the mirror direction
        elif design.lobe == "normalised":
            lobe = normal_lobe_value(wi, wo, m) / normalisation(wi[2], m)
        else:
            lobe = paper_lobe_angles(theta_o, phi_o, theta_r, phi_r, m)
        r = np.array(
            [
                math.pi * (body_brdf(float(rho), float(n), float(tau), ci, wi[2], wo[2]) + fresnel(wi[2], float(n)) * lobe)
                for rho, n, tau, ci in zip(design.rho, design.n, design.tau, c)
            ]
        )
        out.append(colour.lab(r))
    return out


def designed_reading(design, m, order=SOURCE_ORDER):
    """The normalised lobe's reading at the design's geometry with n at 587.6 nm: what
    m(g) inverts."""
    rays = source_rays(design.geometry, order)
    return normalised_reading_focal(design.geometry, design.n_gloss, m, rays, Receptor(design.geometry))


def self_checks():
    """The normalisation against closed forms and a second quadrature."""
    worst = 0.0
    for m in (0.0, 1.0, 30.0, 1e3, 1e5):
        want = 2.0 * math.pi / (m + 2.0)
        got = lobe_normalisation(1.0, m)
        worst = max(worst, abs(got / want - 1.0))
    for mu in (0.05, 0.0872, 0.3, 0.7):
        for m in (0.0, 3.0, 50.0, 2e3):
            a, b = lobe_normalisation(mu, m), lobe_normalisation_mpmath(mu, m)
            worst = max(worst, abs(a / b - 1.0))
    assert worst < 1e-10, worst
    print(f"lobe normalisation self-check: worst relative difference {worst:.2e}", file=sys.stderr)
    # The receptor's solid angle, both ways (a field stop's area in direction space).
    for geometry in (20, 60, 85):
        rec = Receptor(geometry)
        a = rec.integral(lambda th, ph: 1.0 / math.cos(th))
        b = rec.integral_focal_plane(lambda wo: 1.0 / wo[2], np.array(rec.axis), 1.0)
        assert abs(a / b - 1.0) < 1e-10, (geometry, a, b)
    print("receptor solid angle: spherical and focal-plane quadratures agree", file=sys.stderr)


def readings(design, colour, m, order=SOURCE_ORDER):
    """Every reading in output order: (quantity, angle, value)."""
    rows = []
    for angle, lab in zip(ASPECULAR_DEG, multi_angle(design, colour, m)):
        rows += [(name, angle, v) for name, v in zip(("L", "a", "b"), lab)]
    g = gloss_readings(design, colour, m, order, focal=True)
    for geometry in (20, 60, 85):
        rows += [("specular_gu", geometry, g[geometry][0]), ("total_gu", geometry, g[geometry][1])]
    return rows


# Step in ln m of the central differences that give each reading's sensitivity to m.
LN_M_STEP = 1e-3


def main() -> None:
    start = time.time()
    self_checks()
    colour = Colour(read_cie())
    out = []
    for key, path in DESIGNS:
        design = Design(path)
        m = exponent_from_gloss(design)
        m_check = None
        if m is not None:
            rays = source_rays(design.geometry, SOURCE_CHECK_ORDER)
            receptor = Receptor(design.geometry)
            reading = lambda x: normalised_reading_focal(design.geometry, design.n_gloss, math.expm1(x), rays, receptor)  # noqa: E731
            m_check = math.expm1(optimize.brentq(lambda x: reading(x) - design.gu, 0.0, math.log1p(MAX_EXPONENT), xtol=1e-13, rtol=1e-15))
        print(f"{key}: m = {m} ({SOURCE_ORDER} x {SOURCE_ORDER} source points), {m_check} "
              f"({SOURCE_CHECK_ORDER} x {SOURCE_CHECK_ORDER}) ({time.time() - start:.0f} s)", file=sys.stderr)
        miss = designed_reading(design, m) - design.gu if m is not None else 0.0
        print(f"  the root reads the designed gloss to {miss:.2e} GU", file=sys.stderr)
        assert abs(miss) < 1e-9, miss

        base = readings(design, colour, m)
        finer = readings(design, colour, m, SOURCE_CHECK_ORDER)
        # A second quadrature of everything: the lobe normalisation by mpmath in the
        # multi-angle readings, the receptor integrals in spherical coordinates for a
        # 2 x 2 subset of the source rays (against the focal-plane rule on the same rays).
        lab_mp = multi_angle(design, colour, m, lobe_normalisation_mpmath)
        g_sph = gloss_readings(design, colour, m, 2, focal=False)
        g_foc = gloss_readings(design, colour, m, 2, focal=True)
        second = [v for lab in lab_mp for v in lab] + [None] * 6
        if m is None:
            plus = minus = base
            d_gloss = 0.0
        else:
            plus = readings(design, colour, m * math.exp(LN_M_STEP))
            minus = readings(design, colour, m * math.exp(-LN_M_STEP))
            d_gloss = (designed_reading(design, m * math.exp(LN_M_STEP)) - designed_reading(design, m * math.exp(-LN_M_STEP))) / (2 * LN_M_STEP)
        for i, (name, angle, v) in enumerate(base):
            unc = abs(finer[i][2] - v)
            if second[i] is not None:
                unc = max(unc, abs(second[i] - v))
            else:
                k = 0 if name == "specular_gu" else 1
                unc = max(unc, abs(g_sph[angle][k] - g_foc[angle][k]))
            sens = (plus[i][2] - minus[i][2]) / (2 * LN_M_STEP)
            out.append((key, name, angle, v, unc, sens))
        for geometry in (20, 60, 85):
            gu = [v for name, angle, v in base if angle == geometry and name.endswith("_gu")]
            print(f"  {geometry}: {gu} GU; spherical - focal (2 x 2 rays) "
                  f"{g_sph[geometry][0] - g_foc[geometry][0]:.2e}, {g_sph[geometry][1] - g_foc[geometry][1]:.2e}",
                  file=sys.stderr)
        m_unc = abs(m_check - m) if m is not None else 0.0
        out.append((key, "exponent", design.geometry, m if m is not None else math.inf, m_unc, d_gloss))
        print(f"  done ({time.time() - start:.0f} s)", file=sys.stderr)

    versions = ", ".join(f"{p} {importlib.metadata.version(p)}" for p in ("numpy", "scipy", "mpmath"))
    print("# Virtual instrument readings (spec 7 and 4.3), computed independently of the Rust code")
    print(f"# by tools/instrument_reference.py (Python {sys.version.split()[0]}, {versions}) on {datetime.date.today()}.")
    print("# Command: python tools/instrument_reference.py > crates/coatlab-core/tests/data/instrument_reference.csv")
    print("# quantity: L, a, b (CIELAB D65/10; angle_deg = aspecular angle); specular_gu, total_gu (angle_deg =")
    print("# glossmeter geometry); exponent (m from the design's gloss at its geometry angle_deg; inf = mirror).")
    print("# uncertainty: largest difference between the script's own quadratures (source points")
    print(f"# {SOURCE_ORDER} vs {SOURCE_ORDER + 4} a side; receptor in focal-plane vs spherical coordinates; lobe")
    print("# normalisation by SciPy vs mpmath). d_dlnm: d(value)/d(ln m), central difference; on the")
    print("# exponent row, d(reading at the design's geometry, normalised lobe, n at 587.6 nm)/d(ln m).")
    print("# Do not edit.")
    print("design,quantity,angle_deg,value,uncertainty,d_dlnm")
    for key, name, angle, v, unc, sens in out:
        print(f"{key},{name},{angle:g},{float(v)!r},{unc:.2e},{sens:.6e}")


if __name__ == "__main__":
    main()
