"""Per-configuration throughput of explorer's Newton kernels against plain-Python baselines, one run.

    python benchmarks/bench_throughput.py [--variants 2000] [--steps 360] [--dense-variants 500]
        [--numpy-variants 500] [--fsolve-variants 8] [--tolerance 1e-10] [--repeat 3] [--threads N]

Every solver traces the same ±2 % Jansen variants (numpy default_rng(1), the nominal first; only the
ones that assemble all round) through the same crank angles θ_k = 2πk/S and must reach the same
tolerance; a configuration is one (variant, crank angle) pair. Rows:

* block Newton — ``simulate_batch(method="block")``: Numba, dyad by dyad, tangent predictor;
* dense Newton — ``simulate_batch(method="dense")``: Numba, the full 14 x 14 system of seed 000;
* numpy batch Newton — written here: seed 000's 14 x 14 system for all variants at once, one
  ``np.linalg.solve`` on the stacked (N, 14, 14) Jacobians per iteration, secant predictor from the
  two previous angles, iterating until every variant's worst scaled residual |d² − L²| / L² ≤ tol;
* scipy.optimize.fsolve — one call per configuration (with the analytic Jacobian), each from the
  previous angle's solution, on a small subset (it is slow).

Only positions are computed (no velocities). Each timing is the best of --repeat runs after a warm-up
(kernels compiled or loaded from the cache). The machines are shared and noisy: read the ratios. Every
row's foot path is checked against the exact closed form. benchmarks/bench_kernels.py covers block vs
dense vs closed form in more detail; this one is about the numpy and scipy baselines.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import explorer
from _timing import best


class Seed000System:
    """Seed 000's square system for one topology: link residuals |p_b − p_a|² − d² plus the coordinate
    equations of the crank tip and the fixed vertices, unknowns (x1, y1, ..., xn, yn)."""

    def __init__(self, mech):
        self.nv = len(mech.vertices)
        self.a = np.array([mech.vertex_index(l.a) for l in mech.links])
        self.b = np.array([mech.vertex_index(l.b) for l in mech.links])
        self.nl = len(mech.links)
        self.known = [mech.vertex_index(mech.crank.tip)] + [mech.vertex_index(v) for v in mech.fixed]
        self.fixed_xy = np.array([mech.fixed[v] for v in mech.fixed], dtype=float).reshape(-1, 2)
        self.center = np.array(mech.crank.center, dtype=float)

    def targets(self, crank, theta):
        """(N, n_known, 2) positions the coordinate equations pin: the tip at θ, then the fixed vertices."""
        tip = self.center + crank[:, None] * np.array([np.cos(theta), np.sin(theta)])[None, :]
        fixed = np.broadcast_to(self.fixed_xy, (crank.shape[0], *self.fixed_xy.shape))
        return np.concatenate([tip[:, None, :], fixed], axis=1)

    def residual(self, X, L2, T):
        """X (N, nv, 2), L2 (N, nl) squared lengths, T targets -> (F (N, 2nv), worst scaled link residual (N,))."""
        g = X[:, self.b] - X[:, self.a]
        link = np.einsum("nij,nij->ni", g, g) - L2
        coord = (X[:, self.known] - T).reshape(X.shape[0], -1)
        return np.concatenate([link, coord], axis=1), np.max(np.abs(link) / L2, axis=1)

    def jacobian(self, X):
        N, n = X.shape[0], 2 * self.nv
        J = np.zeros((N, n, n))
        g = X[:, self.b] - X[:, self.a]
        rows = np.arange(self.nl)
        for ax in range(2):
            J[:, rows, 2 * self.a + ax] = -2.0 * g[:, :, ax]
            J[:, rows, 2 * self.b + ax] = 2.0 * g[:, :, ax]
        for k, v in enumerate(self.known):
            J[:, self.nl + 2 * k, 2 * v] = 1.0
            J[:, self.nl + 2 * k + 1, 2 * v + 1] = 1.0
        return J


def numpy_batch_newton(system, lengths, crank, steps, P0, tol, max_iterations=50):
    """Foot-independent plain numpy continuation over the cycle for all variants at once.

    Returns (positions (N, S, nv, 2), iterations per configuration (mean), converged (bool)).
    """
    N = lengths.shape[0]
    L2 = lengths ** 2
    X = np.broadcast_to(P0, (N, *P0.shape)).copy()
    prev = None
    out = np.empty((N, steps, system.nv, 2))
    its, converged = 0, True
    for k in range(steps):
        theta = 2.0 * np.pi * k / steps
        T = system.targets(crank, theta)
        if prev is not None:  # secant predictor from the two previous solutions
            X, prev = 2.0 * X - prev, X
        else:
            prev = X.copy()
        for _ in range(max_iterations + 1):
            F, worst = system.residual(X, L2, T)
            if np.all(worst <= tol) and np.all(np.abs(F[:, system.nl:]) <= 1e-12):
                break
            dX = np.linalg.solve(system.jacobian(X), -F[..., None])[..., 0]
            X = X + dX.reshape(N, system.nv, 2)
            its += 1
        else:
            converged = False
        out[:, k] = X
    return out, its / steps, converged


def fsolve_cycle(system, lengths, crank, steps, P0, tol):
    """scipy.optimize.fsolve per configuration (analytic Jacobian), each from the previous solution."""
    from scipy.optimize import fsolve

    out = np.empty((lengths.shape[0], steps, system.nv, 2))
    calls = 0
    for i in range(lengths.shape[0]):
        L2 = lengths[i:i + 1] ** 2
        x = P0.reshape(-1).copy()
        for k in range(steps):
            T = system.targets(crank[i:i + 1], 2.0 * np.pi * k / steps)

            def f(z):
                return system.residual(z.reshape(1, system.nv, 2), L2, T)[0][0]

            def jac(z):
                return system.jacobian(z.reshape(1, system.nv, 2))[0]

            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                x, info, ier, msg = fsolve(f, x, fprime=jac, xtol=tol, full_output=True)
            calls += info["nfev"]
            out[i, k] = x.reshape(system.nv, 2)
    return out, calls / (lengths.shape[0] * steps)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", type=int, default=2000)
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--dense-variants", type=int, default=500)
    ap.add_argument("--numpy-variants", type=int, default=500)
    ap.add_argument("--fsolve-variants", type=int, default=8)
    ap.add_argument("--tolerance", type=float, default=1e-10)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None, help="Numba threads (default: all)")
    a = ap.parse_args(argv)
    import numba

    if a.threads:
        numba.set_num_threads(a.threads)
    mech = explorer.load_mechanism("jansen")
    rng = np.random.default_rng(1)
    L = mech.lengths * (1 + rng.uniform(-0.02, 0.02, (a.variants, len(mech.links))))
    r = mech.crank.radius * (1 + rng.uniform(-0.02, 0.02, a.variants))
    L[0], r[0] = mech.lengths, mech.crank.radius
    S, tol = a.steps, a.tolerance
    closed = explorer.simulate_batch(mech, L, r, S, method="closed", velocities=False, vertices="all")
    keep = closed.status == 0
    L, r = L[keep], r[keep]
    ref = np.stack([closed.paths[v][keep] for v in mech.vertices], axis=2)  # (N, S, nv, 2)
    foot = mech.vertex_index(mech.foot)
    N = len(r)
    P0 = explorer.simulate(mech, 3, method="closed", velocities=False).positions[0]
    system = Seed000System(mech)

    rows = []  # (name, seconds, variants, iterations per configuration, max foot error)

    def kernel(method, n):
        def run():
            return explorer.simulate_batch(mech, L[:n], r[:n], S, method=method, velocities=False, tolerance=tol)
        t = best(run, a.repeat)
        b = run()
        ok = b.status == 0
        err = np.max(np.abs(b.paths[mech.foot][ok] - ref[:n][ok][:, :, foot]))
        return t, float(np.mean(b.iterations[ok]) / S), err, int((~ok).sum())

    t, it, err, bad = kernel("block", N)
    rows.append(("block Newton (numba)", t, N, it, err, bad))
    nd = min(a.dense_variants, N)
    t, it, err, bad = kernel("dense", nd)
    rows.append(("dense Newton (numba)", t, nd, it, err, bad))
    nn = min(a.numpy_variants, N)
    res = {}

    def run_numpy():
        res["out"] = numpy_batch_newton(system, L[:nn], r[:nn], S, P0, tol)
    t = best(run_numpy, max(1, a.repeat - 1))
    pos, it, conv = res["out"]
    rows.append(("numpy batch Newton (np.linalg.solve)", t, nn, it,
                 float(np.max(np.abs(pos[:, :, foot] - ref[:nn, :, foot]))), 0 if conv else nn))
    nf = min(a.fsolve_variants, N)
    t0 = time.perf_counter()
    pos, nfev = fsolve_cycle(system, L[:nf], r[:nf], S, P0, tol)
    t = time.perf_counter() - t0
    rows.append(("scipy.optimize.fsolve (per config)", t, nf, nfev,
                 float(np.max(np.abs(pos[:, :, foot] - ref[:nf, :, foot]))), 0))

    print(f"{N} assembling ±2 % Jansen variants (of {a.variants}) x {S} steps, tolerance {tol:g}, "
          f"{numba.get_num_threads()} numba threads, explorer {explorer.__version__}; best of {a.repeat} "
          "(fsolve: one run)")
    per = {name: t / (n * S) for name, t, n, *_ in rows}
    dense = per["dense Newton (numba)"]
    block = per["block Newton (numba)"]
    print(f"{'solver':38s} {'variants':>8s} {'configs/s':>11s} {'us/config':>10s} {'iter/cfg':>8s} "
          f"{'x dense':>8s} {'x block':>8s} {'max foot err':>12s}")
    for name, t, n, it, err, bad in rows:
        p = per[name]
        note = f"  ({bad} not ok)" if bad else ""
        print(f"{name:38s} {n:8d} {1 / p:11.3g} {1e6 * p:10.3f} {it:8.2f} {p / dense:8.1f} {p / block:8.1f} "
              f"{err:12.1e}{note}")
    print(f"ratios per configuration: dense numba is {per['numpy batch Newton (np.linalg.solve)'] / dense:.1f}x "
          f"faster than the numpy batch and {per['scipy.optimize.fsolve (per config)'] / dense:.0f}x faster than "
          f"fsolve; block numba is {dense / block:.1f}x faster than dense numba "
          f"({per['numpy batch Newton (np.linalg.solve)'] / block:.0f}x the numpy batch, "
          f"{per['scipy.optimize.fsolve (per config)'] / block:.0f}x fsolve)")
    print("(iter/cfg: block counts one iteration per dyad solve (5 per configuration), the others one per full "
          "14x14 solve; fsolve's column is function evaluations per configuration)")


if __name__ == "__main__":
    main()
