"""Independent float64 references built on scipy (complex SH with Condon-Shortley phase)."""
import numpy as np
from scipy import integrate, special


def real_sh_scipy(l, m, theta, phi):
    """Our real basis (no CS phase) from scipy's complex Y_l^m (which has the CS phase)."""
    if m == 0:
        return special.sph_harm_y(l, 0, theta, phi).real
    y = special.sph_harm_y(l, abs(m), theta, phi)
    sign = (-1.0) ** abs(m)  # undo CS
    return np.sqrt(2.0) * sign * (y.real if m > 0 else y.imag)


def basis_scipy(dirs, lmax):
    theta = np.arccos(np.clip(dirs[:, 2], -1, 1))
    phi = np.arctan2(dirs[:, 1], dirs[:, 0])
    return np.stack([real_sh_scipy(l, m, theta, phi) for l in range(lmax + 1) for m in range(-l, l + 1)], -1)


def cell_integral(l, m, y, x, height, width):
    """Integral of Y_lm over pixel (x, y)'s cell of an equirect grid, by adaptive quadrature."""
    t0, t1 = np.pi * y / height, np.pi * (y + 1) / height
    u0, u1 = x / width, (x + 1) / width
    f = lambda u, t: real_sh_scipy(l, m, t, np.pi - 2 * np.pi * u) * np.sin(t) * 2 * np.pi  # noqa: E731
    val, _ = integrate.dblquad(f, t0, t1, u0, u1, epsabs=1e-14, epsrel=1e-12)
    return val
