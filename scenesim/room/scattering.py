"""Diffuse (scattered) wall reflections: exact specular images + a directional energy-decay model
of the scattered energy, rendered as coherent noise (issue 18).

Method, and why.  Each wall ``w`` has an energy absorption ``alpha_w`` and a scattering
coefficient ``s_w`` (ISO 17497-1: the share of the reflected energy that leaves non-
specularly).  A sound ray hitting it keeps ``(1 - alpha)(1 - s)`` specularly, sends
``(1 - alpha) s`` into all directions (Lambert) and loses ``alpha``.  So:

* **Specular part: the image-source method, exact**, with the wall pressure reflections
  ``sqrt((1 - alpha)(1 - s))`` -- every specular reflection keeps its exact delay, direction
  and inter-mic cues (what a randomised ISM would jitter and a ray tracer would only sample).
* **Scattered part: an energy-decay model driven by the scattered energy** (a directional
  radiative-transfer balance on the sphere of directions, in the spirit of Kuttruff's
  integral-equation / acoustic radiance-transfer models): the specular field's expected
  energy per direction ``u`` is the ISM's own, ``e_s(u, t) = c / (4 pi V fs) exp(-c t
  sum_d l_d u_d / L_d)`` (``l_d`` the mean per-hit log loss of axis d's two walls,
  :mod:`scenesim.room.hybrid`); a direction hits the walls of axis d ``c u_d / L_d`` times a
  second, each hit moving the share ``phi_d = ln(1 - s) / ln((1 - alpha)(1 - s))`` of its
  per-hit log loss into the scattered field (the rest is absorbed).  Scattered energy leaves
  the walls as Lambert emission -- into direction u in proportion to the wall area projected
  on u, i.e. to u's hit rate ``h(u) = c sum_d u_d / L_d`` -- and then decays and re-scatters
  by the same rules::

      d e_d(u)/dt = -mu(u) e_d(u) + h(u) / <h> I(t),   mu(u) = c sum_d u_d l_d / L_d,
      I(t) = < (e_s(u', t) + e_d(u', t)) c sum_d u'_d l_d phi_d / L_d >_{u'}

  (for the scattered field the two walls of an axis are averaged in energy, not in log: it
  meets them in random order).  Integrated on 144 directions (Gauss-Legendre on the octant)
  as a scalar Volterra equation (the redistribution is rank one) by product integration with
  0.5 ms linear hats -- exact per exponential, stable however stiff strong scattering makes it --
  from the direct arrival on.  Closed-form checks
  (``tests/test_scattering.py``): without absorption energy is conserved (7e-6); a uniformly
  absorbing, fully scattering room keeps an isotropic field that decays at Eyring's rate.
  Its mean over directions is the expected
  ``h^2`` per tap of the scattered part, rendered as Gaussian noise with that envelope and the
  diffuse-field coherence ``sinc(2 f d / c)`` between mics (:func:`scenesim.room.hybrid.coherent_noise`).

Why this and not the alternatives: a randomised ISM keeps only a jittered specular lattice
and cannot move energy between directions (the cause of the two-slope decay of corridors and
rooms with one absorptive wall: grazing and axial directions that never meet the absorber
decay slowly); a ray-traced diffuse rain needs ~10^4-10^5 rays per band and source (seconds per
RIR here, and noise in the late decay).  The directional model gives the expected scattered
energy of a shoebox in milliseconds, deterministic up to the tail's noise, and is exactly what
mixes the slow and fast directions -- so EDT and T30 come together as in real furnished rooms.
Not modelled: the directivity of the source in the scattered energy (taken as the omni
source's), edge diffraction, and the non-Lambert lobe of real scatterers.

Default :data:`DEFAULT_SCATTERING` = 0.5 (every wall, every band), used by
:func:`scenesim.room.calibration.calibrate_room` and the rooms built from it.  Why 0.5: bare smooth
walls measure 0.05-0.1 (ISO 17497-1 random-incidence values), furniture, shelves, desks and
people 0.4-0.8 at speech frequencies -- and an empty shoebox standing in for a furnished room
must carry the furniture's diffusion on its walls.  Measured with the calibration
(``benchmarks/studies/rooms_check.py``): at 0.3 an open office (absorptive ceiling) still
decays in two slopes (EDT -24..-26 %, C50 +2.9..+4.2 dB off the diffuse field); at 0.5 the
three unseen test rooms (corridor, one absorptive wall, open office) are within T30 -1.5..+4.4 %,
EDT -5.8..+11 %, C50 -0.96..+0.70 dB.  ``ShoeBox(scattering=None)`` (the class default) is the
purely specular ISM that pyroomacoustics' ISM reproduces.

Cross-check: pyroomacoustics' hybrid ray tracer with the same absorption and scattering
(:mod:`scenesim.room.crosscheck_scattering`, ``scenesim rir --compare``) decays faster than this model
and even faster than Eyring in a uniform corridor: its scattered energy is sent to the receiver
once (diffuse rain) and removed from the ray rather than continuing as a diffuse ray
(pyroomacoustics issue #415, open: "raising the scattering make[s] the reverberation much
shorter").  The differences are printed, not hidden; the tests use closed forms instead
(energy conservation without absorption, Eyring's rate for an isotropic field).
"""

from __future__ import annotations

import math

import numpy as np

from scenesim.room.hybrid import _octant_directions, coherent_noise

DEFAULT_SCATTERING = 0.5
"""Scattering coefficient of every wall and band in calibrated rooms (module docstring)."""
_STEP_S = 0.0005  # time step of the energy balance (s); the envelope is smooth on this scale
_N_DIR = 12  # Gauss-Legendre nodes per angle on the octant (144 directions)


def _integrate(mu, inject, lambert, w, src_mu, src_coef, n_points: int) -> np.ndarray:
    """Mean scattered energy at every step of ``de/dt = -mu e + lambert (inject . e + source(t))``.

    ``mu``, ``inject`` (already times the quadrature weights ``w``), ``lambert``, ``w`` (n_dir,);
    ``source(t) = sum_u src_coef_u exp(-src_mu_u t)`` (the specular field's scattered power),
    taken at the ``n_points`` step times and linear in between.  With ``f = inject . e +
    source`` linear over a step of length h, each direction's update is exact:
    ``e_k = e^{-a} e_{k-1} + lambert h (e^{-a} R(a) f_{k-1} + L(a) f_k)``, ``a = mu h``,
    ``R = (e^a - 1 - a) / a^2``, ``L = (e^{-a} - 1 + a) / a^2`` (product integration with linear
    hats); ``f_k`` appears on both sides and is solved for (a scalar).  Stable however stiff
    strong scattering makes it.
    """
    from scenesim.room.ism_kernels import scattered_steps  # lazy: numba

    h = _STEP_S
    a = np.maximum(mu * h, 1e-12)
    small = a < 1e-3
    em = np.exp(-a)
    # e^{-a} R(a) and L(a), by series for small a (cancellation).
    r_shift = np.where(small, 0.5 - a / 3.0, (1.0 - em * (1.0 + a)) / np.maximum(a * a, 1e-300))
    left = np.where(small, 0.5 - a / 6.0, (em - 1.0 + a) / np.maximum(a * a, 1e-300))
    out = np.zeros(n_points)
    scattered_steps(em, lambert * h * r_shift, lambert * h * left, inject, w, np.exp(-src_mu * h), src_coef, out)
    return out


def _axis_rates(reflection, scattering, *, diffuse: bool):
    """Per band and axis: per-hit log loss ``l (n_bands, 3)`` and scattered share ``phi (n_bands, 3)``.

    ``reflection`` (n_bands, 6): total wall pressure reflections ``sqrt(1 - alpha)``;
    ``scattering`` (n_bands, 6).  In continuous time a hit's log loss
    ``-ln((1 - alpha)(1 - s))`` splits into absorption ``-ln(1 - alpha)`` and scattering
    ``-ln(1 - s)``, so ``phi = ln(1 - s) / ln((1 - alpha)(1 - s))`` and a field loses exactly
    the absorbed energy.  The two walls of an axis: a specular direction meets them in turn
    (mean of the logs, exactly the ISM's decay); scattered energy meets them in random order,
    so its per-hit factors are averaged in energy (``diffuse``; Eyring's mean when isotropic).
    """
    keep = np.clip(np.asarray(reflection, dtype=float) ** 2, 1e-12, 1.0)  # 1 - alpha
    stay = 1.0 - np.asarray(scattering, dtype=float)
    if diffuse:
        keep = np.repeat(0.5 * (keep[:, 0::2] + keep[:, 1::2]), 2, axis=1)
        stay = np.repeat(0.5 * (stay[:, 0::2] + stay[:, 1::2]), 2, axis=1)
    absorb, scat = -np.log(keep), -np.log(stay)
    total = absorb + scat
    loss = 0.5 * (total[:, 0::2] + total[:, 1::2])
    phi = (scat[:, 0::2] + scat[:, 1::2]) / np.maximum(total[:, 0::2] + total[:, 1::2], 1e-300)
    return loss, phi


def scattered_energy(dims_m, reflection, scattering, n_taps: int, *, fs: int, c: float, t0_s: float) -> np.ndarray:
    """Expected ``h^2`` per tap ``(n_bands, n_taps)`` of the scattered field (module docstring).

    ``reflection`` (n_bands, 6) total wall pressure reflections, ``scattering`` (n_bands, 6);
    zero before ``t0_s`` (the direct arrival).

    Example: with ``s = 0`` there is no scattered energy.

    >>> e = scattered_energy((5, 4, 3), np.full((1, 6), 0.8), np.zeros((1, 6)), 100, fs=1000, c=343.0, t0_s=0.01)
    >>> float(e.max())
    0.0
    """
    dims = np.asarray(dims_m, dtype=float)
    u, w = _octant_directions(_N_DIR, _N_DIR)
    hits = c * u / dims  # (n_dir, 3) hits per second on each axis
    rates = []
    for diffuse in (False, True):  # specular field, scattered field
        loss, phi = _axis_rates(reflection, scattering, diffuse=diffuse)
        # log-energy loss per second, and scattered energy per second per unit energy: (n_bands, n_dir)
        rates.append((loss @ hits.T, (loss * phi) @ hits.T))
    (mu_s, inj_s), (mu, inj_d) = rates
    # Lambert emission: walls send scattered energy into direction u in proportion to their
    # area projected on u, i.e. to u's wall-hit rate; normalised to a unit mean over directions.
    lambert = hits.sum(axis=1) / float(hits.sum(axis=1) @ w)
    level = c / (4.0 * np.pi * float(np.prod(dims)) * fs)
    n_steps = int(math.ceil(n_taps / fs / _STEP_S)) + 1
    times = t0_s + np.arange(n_steps + 1) * _STEP_S
    out = np.zeros((mu.shape[0], n_steps + 1))
    for b in range(mu.shape[0]):
        # Scattered power from the specular field: closed form per direction, stepped in the kernel.
        out[b] = _integrate(mu[b], inj_d[b] * w, lambert, w, mu_s[b], level * inj_s[b] * w, times.size)
    t_tap = np.arange(n_taps) / fs
    t_tap = np.arange(n_taps) / fs
    res = np.zeros((mu.shape[0], n_taps))
    for b in range(mu.shape[0]):
        res[b] = np.interp(t_tap, times, out[b], left=0.0)
    return res


def scattered_tail(dims_m, reflection, scattering, mics_m, *, n_taps: int, fs: int, c: float, t0_s: float,
                   rng, noise=None, energy=None) -> np.ndarray:
    """The scattered part ``(n_bands, n_mics, n_taps)``: diffuse-coherent noise x sqrt(expected energy).

    ``noise`` ``(n_mics, n_taps)``: the coherent-noise realisation, else drawn from ``rng``;
    ``energy`` ``(n_bands, n_taps)``: :func:`scattered_energy` of these arguments, if already known.
    """
    env2 = scattered_energy(dims_m, reflection, scattering, n_taps, fs=fs, c=c, t0_s=t0_s) if energy is None \
        else energy
    if noise is None:
        noise = coherent_noise(mics_m, n_taps, fs=fs, c=c, rng=rng)
    return noise[None, :, :] * np.sqrt(env2)[:, None, :]


__all__ = ["DEFAULT_SCATTERING", "scattered_energy", "scattered_tail"]
