r"""Closed-form contact solutions: references for tests and first guesses for fits.

Hertz (paraboloid approximation of the sphere, small strain)

.. math::

    F = \frac{4}{3} \frac{E}{1 - \nu^2} \sqrt{R}\, h^{3/2}

and Sneddon's exact small-strain solution for a sphere, in terms of the contact
radius a:

.. math::

    h = \frac{a}{2} \ln\frac{R + a}{R - a}, \qquad
    F = \frac{E^*}{2}\left[(a^2 + R^2)\ln\frac{R + a}{R - a} - 2 a R\right].
"""

from __future__ import annotations

import numpy as np


def reduced_modulus(E_kPa, nu):
    """E* = E / (1 - nu^2), kPa."""
    return E_kPa / (1.0 - np.asarray(nu) ** 2)


def hertz_force(depth_mm, E_kPa, nu, radius_mm):
    """Hertz force (mN) of a rigid sphere on an elastic half-space.

    Parameters
    ----------
    depth_mm : array_like
        Indentation depth h, mm (negative depths give zero force).
    E_kPa : float
        Young's modulus, kPa.
    nu : float
        Poisson's ratio.
    radius_mm : float
        Sphere radius R, mm.
    """
    h = np.maximum(np.asarray(depth_mm, dtype=float), 0.0)
    return 4.0 / 3.0 * reduced_modulus(E_kPa, nu) * np.sqrt(radius_mm) * h**1.5


def sneddon_sphere_force(depth_mm, E_kPa, nu, radius_mm):
    """Sneddon's exact small-strain force (mN) for a rigid sphere (not a paraboloid).

    Parameters are those of :func:`hertz_force`; valid for depths below R.
    """
    from scipy.optimize import brentq  # lazy: scipy.optimize is slow to import

    h = np.atleast_1d(np.asarray(depth_mm, dtype=float))
    R = radius_mm
    out = np.zeros_like(h)
    for i, hi in enumerate(h):
        if hi <= 0:
            continue
        a = brentq(lambda a: 0.5 * a * np.log((R + a) / (R - a)) - hi, 1e-12 * R, R * (1 - 1e-12))
        out[i] = 0.5 * reduced_modulus(E_kPa, nu) * ((a**2 + R**2) * np.log((R + a) / (R - a)) - 2 * a * R)
    return out if np.ndim(depth_mm) else float(out[0])


def ting_ramp_force(time_s, speed_mm_per_s, E_kPa, nu, radius_mm, prony):
    r"""Force (mN) of a viscoelastic half-space under a sphere pushed at constant speed.

    Lee-Radok / Ting solution for monotone loading at small strain, with the
    relaxation modulus ``E(t) = E (g_inf + sum g_i exp(-t / tau_i))`` and constant nu:

    .. math::

        F(t) = \frac{4\sqrt{R}}{3(1-\nu^2)} \int_0^t E(t-s) \frac{d h^{3/2}}{ds} ds
             = \frac{2\sqrt{R}\, v^{3/2} E}{1-\nu^2}\Big[\frac{2}{3} g_\infty t^{3/2}
               + \sum_i g_i \tau_i^{3/2} \big(u_i - D(u_i)\big)\Big],\quad u_i = \sqrt{t/\tau_i},

    with D Dawson's integral (``scipy.special.dawsn``).

    Parameters
    ----------
    time_s : array_like
        Time since first contact, s.
    speed_mm_per_s : float
        Loading speed v, mm/s (depth h = v t).
    E_kPa, nu : float
        Instantaneous modulus and Poisson's ratio.
    radius_mm : float
        Sphere radius R, mm.
    prony : sequence of (g, tau_s)
        Prony terms.
    """
    from scipy.special import dawsn

    t = np.maximum(np.asarray(time_s, dtype=float), 0.0)
    g_inf = 1.0 - sum(g for g, _ in prony)
    total = 2.0 / 3.0 * g_inf * t**1.5
    for g, tau in prony:
        u = np.sqrt(t / tau)
        total = total + g * tau**1.5 * (u - dawsn(u))
    return 2.0 * np.sqrt(radius_mm) * speed_mm_per_s**1.5 * E_kPa / (1.0 - nu**2) * total


def ting_power_law_force(time_s, speed_mm_per_s, E_kPa, nu, radius_mm, beta, *, t0_s=1.0, peak_s=None):
    r"""Force (mN) of a power-law viscoelastic half-space under a sphere, loaded and unloaded at constant speed.

    Lee-Radok / Ting solution at small strain for the relaxation modulus
    :math:`E(t) = E (t/t_0)^{-\beta}` and constant nu, depth h = v t up to ``peak_s``, then
    h = v (2 t_m - t). Loading:

    .. math::

        F(t) = \frac{4\sqrt R}{3(1-\nu^2)} \int_0^t E(t-s) \frac{d h^{3/2}}{ds} ds
             = \frac{4\sqrt R}{3(1-\nu^2)} E t_0^\beta v^{3/2} \frac32 B(\tfrac32, 1-\beta)\, t^{3/2-\beta}.

    Unloading (Ting 1966): the contact radius of time t is that of the earlier time t_1 with
    :math:`\int_{t_1}^t E(t-s) \dot h(s) ds = 0`, here :math:`t - t_1 = 2^{1/(1-\beta)} (t - t_m)`,
    and F(t) is the loading integral up to t_1, an incomplete Beta function:
    :math:`F(t) = F_\mathrm{load}(t)\, I_{t_1/t}(\tfrac32, 1-\beta)`; the contact is lost (F = 0)
    once :math:`t_1 \le 0`.

    Parameters
    ----------
    time_s : array_like
        Time since first contact, s.
    speed_mm_per_s : float
        Speed v, mm/s.
    E_kPa : float
        Relaxation modulus at ``t0_s``, kPa.
    nu : float
        Poisson's ratio.
    radius_mm : float
        Sphere radius R, mm.
    beta : float
        Exponent, in [0, 1).
    t0_s : float
        Reference time, s.
    peak_s : float, optional
        Time of the deepest point (None: loading only).
    """
    from scipy.special import beta as beta_fn
    from scipy.special import betainc

    t = np.maximum(np.asarray(time_s, dtype=float), 0.0)
    load = (4.0 * np.sqrt(radius_mm) / (3.0 * (1.0 - nu**2)) * E_kPa * t0_s**beta * speed_mm_per_s**1.5
            * 1.5 * beta_fn(1.5, 1.0 - beta) * t ** (1.5 - beta))
    if peak_s is None:
        return load
    t1 = t - 2.0 ** (1.0 / (1.0 - beta)) * np.maximum(t - peak_s, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(t1 > 0, betainc(1.5, 1.0 - beta, np.clip(t1 / np.where(t > 0, t, 1.0), 0.0, 1.0)), 0.0)
    return np.where(t > peak_s, load * frac, load)


def dimitriadis_bonded_force(depth_mm, E_kPa, nu, radius_mm, thickness_mm):
    r"""Sphere on a thin elastic layer bonded to a rigid base (Dimitriadis et al. 2002).

    Small-strain Hertz force times the bonded-layer correction, valid for
    :math:`\chi = \sqrt{R h} / t < 1`:

    .. math::

        F = F_H \Big[1 - \frac{2\alpha_0}{\pi}\chi + \frac{4\alpha_0^2}{\pi^2}\chi^2
            - \frac{8}{\pi^3}\Big(\alpha_0^3 + \frac{4\pi^2}{15}\beta_0\Big)\chi^3
            + \frac{16\alpha_0}{\pi^4}\Big(\alpha_0^3 + \frac{3\pi^2}{5}\beta_0\Big)\chi^4\Big]

    with :math:`\alpha_0 = -(1.2876 - 1.4678\nu + 1.3442\nu^2)/(1-\nu)` and
    :math:`\beta_0 = (0.6387 - 1.0277\nu + 1.5164\nu^2)/(1-\nu)`.

    Parameters
    ----------
    depth_mm, E_kPa, nu, radius_mm : as in :func:`hertz_force`
    thickness_mm : float
        Layer thickness t, mm.
    """
    chi = np.sqrt(radius_mm * np.maximum(np.asarray(depth_mm, dtype=float), 0.0)) / thickness_mm
    a0 = -(1.2876 - 1.4678 * nu + 1.3442 * nu**2) / (1 - nu)
    b0 = (0.6387 - 1.0277 * nu + 1.5164 * nu**2) / (1 - nu)
    pi = np.pi
    corr = (1 - 2 * a0 / pi * chi + 4 * a0**2 / pi**2 * chi**2 - 8 / pi**3 * (a0**3 + 4 * pi**2 / 15 * b0) * chi**3
            + 16 * a0 / pi**4 * (a0**3 + 3 * pi**2 / 5 * b0) * chi**4)
    return hertz_force(depth_mm, E_kPa, nu, radius_mm) * corr


def hertz_contact_radius(depth_mm, radius_mm):
    """Hertz contact radius a = sqrt(R h), mm."""
    return np.sqrt(radius_mm * np.maximum(np.asarray(depth_mm, dtype=float), 0.0))
