#!/usr/bin/env python3
"""Reference values of the coat integral C(n, tau) (spec 4.1) at 40 significant digits.

    C(n, tau) = 2 pi Int_0^{pi/2} R_int(t) cos t sin t exp(-2 tau / cos t) dt

t is the polar angle inside the coat; R_int = 1 beyond the critical angle asin(1/n)
and the unpolarised Fresnel reflectance of the outside angle that refracts to t
otherwise (spec 3). C underflows f64 beyond tau ~ 370, so the table holds the scaled
value C * exp(2 tau), which stays representable up to tau = 1e4.

This shares no code or method with crates/coatlab-core/src/paint/: the Fresnel
formula is written again here, the integral is taken in the inside angle t (the
implementation integrates in the outside cosine), with mpmath's tanh-sinh
quadrature split at the critical angle and at the decay scales of the exponential.
Before any row is written, the quadrature is checked against two closed forms and
a second quadrature, to 1e-20 relative:
  - the total-internal-reflection part is 2 pi u_c^2 E_3(2 tau / u_c), with
    u_c = sqrt(1 - 1/n^2) the inside cosine at the critical angle;
  - at tau = 0 the Fresnel part is pi r_e / n^2, with r_e the outside diffuse
    (cosine-weighted hemispherical) reflectance in the closed form of Stern (1964);
  - the Fresnel part is integrated a second time in the inside cosine u = cos t.

Usage (writes crates/coatlab-core/tests/data/c_integral_reference.csv, ~1 minute):
    python3 -m venv /tmp/cint-venv && /tmp/cint-venv/bin/pip install -r tools/requirements.txt
    /tmp/cint-venv/bin/python tools/c_integral_reference.py \
        > crates/coatlab-core/tests/data/c_integral_reference.csv

Progress goes to stderr. Columns: n, tau (shortest decimal that round-trips to the
f64 the Rust tests pass), c_scaled = C exp(2 tau) with 20 significant digits,
c = C rounded to f64 (0 where it underflows).
"""

import importlib.metadata
import sys
import time

from mpmath import mp, mpf

mp.dps = 40

N_GRID = ["1", "1.0001", "1.01", "1.1", "1.3", "1.5", "1.567", "2", "2.5", "3", "4"]
TAU_GRID = [
    "0", "1e-6", "1e-3", "0.01", "0.05", "0.1", "0.3", "1", "3", "10", "30",
    "100", "300", "1000", "3000", "1e4",
]

# Relative agreement demanded between the quadrature and the closed forms: five
# orders of magnitude beyond the f64 digits the table is used for.
CHECK_REL = mpf("1e-20")


def fresnel_unpolarised(mu_out, mu_in, n):
    """Unpolarised Fresnel reflectance from the two cosines either side of the surface."""
    rs = (mu_out - n * mu_in) / (mu_out + n * mu_in)
    rp = (n * mu_out - mu_in) / (n * mu_out + mu_in)
    return (rs * rs + rp * rp) / 2


def r_internal(t, n):
    """Reflectance seen from inside the coat at inside angle t below the critical angle."""
    s = n * mp.sin(t)  # sine of the outside angle, by Snell
    # Clamp the rounding just below the critical angle (sqrt of a negative is complex).
    mu_out = mp.sqrt(max(1 - s * s, mpf(0)))
    return fresnel_unpolarised(mu_out, mp.cos(t), n)


def exponent(t, tau):
    """2 tau (1/cos t - 1): the round-trip absorption exponent, less the 2 tau scaled out."""
    return 2 * tau * (1 / mp.cos(t) - 1)


def scale_points(tau, lo, hi):
    """Inside angles in (lo, hi) where the exponent has grown by 1, 4, 16, ... over its
    value at lo.

    For large tau the integrand is a narrow peak at t = 0 (width ~ 1/sqrt(tau)), and on
    the TIR segment of a coat with n near 1 it falls by e-folds over a tiny fraction of
    the segment; splitting there lets tanh-sinh resolve the decay instead of sampling
    a flat zero.
    """
    pts = []
    if tau == 0:
        return pts
    g_lo = exponent(lo, tau)
    x = mpf(1)
    while x < 1e6:
        t = mp.acos(1 / (1 + (g_lo + x) / (2 * tau)))
        if lo < t < hi:
            pts.append(t)
        x *= 4
    return pts


def integrate_segment(reflectance, lo, hi, tau):
    """Int_lo^hi reflectance(t) cos t sin t exp(-2 tau (1/cos t - 1)) dt, with an error
    estimate.

    mpmath.quad judges convergence against an absolute epsilon, so an integrand of
    size 1e-60 "converges" at once to a wrong value (seen on the TIR segment of
    n = 1.0001). The integrand handed to it is therefore normalised to O(1): the
    exponent at lo is factored out and the rest divided by its largest sampled size.
    """
    g_lo = exponent(lo, tau)
    pts = [lo] + scale_points(tau, lo, hi) + [hi]

    def raw(t):
        return reflectance(t) * mp.cos(t) * mp.sin(t) * mp.exp(g_lo - exponent(t, tau))

    probes = [lo + (hi - lo) * k / 64 for k in range(1, 64)] + pts[1:-1]
    probes += [(p + q) / 2 for p, q in zip(pts, pts[1:])]
    size = max(abs(raw(t)) for t in probes)
    if size == 0:
        size = mpf(1)
    value, err = mp.quad(lambda t: raw(t) / size, pts, method="tanh-sinh", error=True)
    factor = size * mp.exp(-g_lo)
    return value * factor, err * factor


def fresnel_part_in_inside_cosine(n, tau):
    """The Fresnel part again, in the inside cosine u = cos t instead of t: a second
    quadrature in another variable to check the first where no closed form exists."""
    u_c = mp.sqrt(1 - 1 / (n * n))

    def reflectance(u):
        mu_out = mp.sqrt(max(1 - n * n * (1 - u * u), mpf(0)))
        return fresnel_unpolarised(mu_out, u, n)

    def raw(u):
        return reflectance(u) * u * mp.exp(-2 * tau * (1 / u - 1))

    # The large-tau peak sits at u = 1 with width 1/(2 tau).
    pts = [u_c] + [1 - mpf(4) ** k / (2 * tau) for k in range(-3, 12) if tau > 0]
    pts = sorted(p for p in pts if u_c <= p < 1) + [mpf(1)]
    size = max(abs(raw(u)) for u in pts[1:])
    return mp.quad(lambda u: raw(u) / size, pts, method="tanh-sinh") * size


def diffuse_reflectance_stern(n):
    """Outside diffuse reflectance r_e = 2 Int_0^1 R(mu) mu dmu, closed form (n > 1).

    Stern, Appl. Opt. 3, 111 (1964); the same expression as in Egan & Hilgeman,
    Optical Properties of Inhomogeneous Materials (1979), eq. for unpolarised light.
    """
    n2 = n * n
    n4 = n2 * n2
    return (
        mpf(1) / 2
        + (n - 1) * (3 * n + 1) / (6 * (n + 1) ** 2)
        + n2 * (n2 - 1) ** 2 / (n2 + 1) ** 3 * mp.log((n - 1) / (n + 1))
        - 2 * n**3 * (n2 + 2 * n - 1) / ((n2 + 1) * (n4 - 1))
        + 8 * n4 * (n4 + 1) / ((n2 + 1) * (n4 - 1) ** 2) * mp.log(n)
    )


WORST_CHECK = [mpf(0)]


def check(value, exact, what):
    rel = abs(value - exact) / abs(exact)
    WORST_CHECK[0] = max(WORST_CHECK[0], rel)
    assert rel <= CHECK_REL, (what, value, exact)


def c_scaled(n, tau):
    """C(n, tau) e^{2 tau} and an error estimate, cross-checked as the module says."""
    if n == 1:
        # mu_out = mu_in identically, so rs = rp = 0 and there is no critical angle.
        return mpf(0), mpf(0)
    t_c = mp.asin(1 / n)
    fres, err_f = integrate_segment(lambda t: r_internal(t, n), mpf(0), t_c, tau)
    tir, err_t = integrate_segment(lambda t: mpf(1), t_c, mp.pi / 2, tau)

    # Closed form of the TIR part: with u = cos t and u = u_c / s,
    # Int_0^{u_c} u e^{-2 tau / u} du = u_c^2 E_3(2 tau / u_c).
    u_c = mp.sqrt(1 - 1 / (n * n))
    if tau == 0:
        tir_exact = u_c**2 / 2
    else:
        tir_exact = u_c**2 * mp.expint(3, 2 * tau / u_c) * mp.exp(2 * tau)
    check(tir, tir_exact, (n, tau, "TIR part"))

    if tau == 0:
        # Reciprocity (mu_in dmu_in = mu_out dmu_out / n^2) maps the Fresnel part onto
        # the outside hemisphere: 2 pi Int R mu_in dmu_in = pi r_e / n^2.
        fres_exact = diffuse_reflectance_stern(n) / (n * n) / 2
        check(fres, fres_exact, (n, tau, "Fresnel part"))
    check(fres, fresnel_part_in_inside_cosine(n, tau), (n, tau, "Fresnel part in u"))

    value = 2 * mp.pi * (fres + tir)
    err = 2 * mp.pi * (err_f + err_t)
    return value, err


def main() -> None:
    start = time.time()
    print("# C(n, tau) of spec 4.1: c_scaled = C * exp(2 tau) (20 significant digits),")
    print("# c = C as f64 (0 where it underflows). mpmath "
          f"{importlib.metadata.version('mpmath')}, {mp.dps} digits, tanh-sinh in the")
    print("# inside angle. Generated by tools/c_integral_reference.py; do not edit.")
    print("n,tau,c_scaled,c")
    worst_err = mpf(0)
    for n_str in N_GRID:
        # Use the exact binary value the Rust test will pass, not the decimal.
        n = mpf(float(n_str))
        for tau_str in TAU_GRID:
            tau = mpf(float(tau_str))
            value, err = c_scaled(n, tau)
            if value != 0:
                worst_err = max(worst_err, err / value)
            c_f64 = float(value * mp.exp(-2 * tau))
            print(f"{float(n_str)!r},{float(tau_str)!r},{mp.nstr(value, 20)},{c_f64!r}")
        print(
            f"n = {n_str}: done ({time.time() - start:.1f} s)",
            file=sys.stderr,
        )
    print(f"largest relative error estimate of mpmath.quad: {mp.nstr(worst_err, 3)}",
          file=sys.stderr)
    print(f"largest relative difference in the cross-checks: {mp.nstr(WORST_CHECK[0], 3)}",
          file=sys.stderr)


if __name__ == "__main__":
    main()
