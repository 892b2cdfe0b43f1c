"""Run one design's MuJoCo model and measure whole turns (the physics metrics of one design).

The model (:mod:`explorer.physics._model`) starts as the kinematic machine at θ = 0 (every member at
its solved pose and speed, the contact foot planted, the body at the speed that keeps it planted). It
is stepped natively (``mujoco.rollout``: one C call per crank turn, no Python per step) for
``settle`` turns, which are not measured, then for ``turns`` whole turns, which are. A turn is a whole
number of steps n (the timestep is shortened to fit), a multiple of the S samples per turn.

Measured, over the K measured turns (t ∈ [t_s, t_s + K·T), T = 60/rpm):

* ``physics_travel`` (m/turn): the body's displacement along the kinematic walking direction / K;
* ``physics_bob`` (m): max − min of the body's height; ``physics_pitch`` (rad): max − min of its
  pitch (0 when held);
* ``physics_loaded_feet_max``: the most feet loaded at once at the S samples per turn (θ_k = 2πk/S):
  a foot is loaded when its normal force exceeds ``loaded`` × the machine's weight;
* ``physics_friction_work`` (J/turn): Σ over steps and feet of |F_x·v_slip|·dt / K, F_x the ground's
  horizontal force on the foot and v_slip the horizontal speed of the foot sphere's lowest point
  (v_centre,x − ρ·Ω_y): the work the feet's friction dissipates, mostly where feet that share the
  ground fight (a foot that rolls or stands does almost none);
* ``physics_torque_peak``, ``physics_torque_rms`` (N·m): the motor torque (the two servos' sum, positive
  when the motor does positive work) averaged over the K turns at each of the S crank angles (the
  phase average), then max |τ̄| and √mean τ̄²;
* ``physics_impact_peak`` (N): the largest normal force on a foot within ``impact_window`` of crank
  angle after it lands (touches the ground after a swing): what a handover hits the foot with. It
  depends on the contact's stiffness (solref: a time constant of 2 timesteps, critically damped), so
  compare designs with it, not with a load cell;
* ``physics_travel_diff`` (%): 100·(physics_travel − travel)/travel, travel the kinematic walker's.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ._model import Model, Settings, build_model

#: The physics metrics, in the order of the metric table's ``physics`` group.
PHYSICS_METRICS = ("physics_travel", "physics_bob", "physics_pitch", "physics_loaded_feet_max",
                   "physics_friction_work", "physics_torque_peak", "physics_torque_rms", "physics_impact_peak",
                   "physics_travel_diff")


class PhysicsFailure(Exception):
    """The simulation of one design did not give trustworthy figures (the reason, in words)."""


def steps_per_turn(omega: float, timestep: float, samples: int) -> int:
    """Steps n per crank turn: the least multiple of ``samples`` with T/n ≤ ``timestep``."""
    T = 2.0 * math.pi / omega
    return samples * max(1, math.ceil(T / (timestep * samples) - 1e-9))


def run_model(model: Model, samples: int, kinematic_travel: float | None = None) -> dict:
    """Simulate ``model`` and measure (see the module docstring). ``samples``: S, the crank angles per
    turn at which loaded feet are counted and the torque is phase-averaged. ``kinematic_travel``: the
    kinematic walker's travel, m/turn (for ``physics_travel_diff``). Returns {metric: float} plus
    ``cpu_s`` and ``series`` (what a plot needs: theta (S,), torque (S,), per-sample normal forces
    (S, L) phase-averaged, body height (K·S,)). Raises :class:`PhysicsFailure`."""
    import mujoco

    t0 = time.process_time()
    st: Settings = model.settings
    m = mujoco.MjModel.from_xml_string(model.xml)
    n = steps_per_turn(model.omega, st.timestep, samples)
    dt = 2.0 * math.pi / model.omega / n
    m.opt.timestep = dt
    d = mujoco.MjData(m)
    d.qvel[:] = model.qvel0
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    n_settle = int(round(st.settle * n))
    K = int(st.turns)
    total = n_settle + K * n
    first = state.copy()
    states, sensors = [], []
    warnings: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warnings.append)  # MuJoCo's warnings become this design's failure, not stderr
    try:
        _roll(m, d, model, state, n, dt, total, states, sensors, warnings)
    finally:
        mujoco.set_mju_user_warning(previous)
    # row i: the state after step i, at t = (i + 1)·dt; the measured window is steps n_settle … total − 1
    S_all = np.concatenate([first[None, :]] + states)[n_settle:]  # K·n + 1 states: t = n_settle·dt … total·dt
    X_all = np.concatenate(sensors)[n_settle:]  # K·n sensor rows, after each measured step
    if not (np.all(np.isfinite(S_all)) and np.all(np.isfinite(X_all))):
        raise PhysicsFailure("the simulation diverged (a non-finite state): the model is too stiff for its "
                             "timestep or a loop cannot close")
    gap = _loop_gap(m, d, states[-1][-1])
    if gap > LOOP_GAP * model.crank_radius:
        raise PhysicsFailure(f"its loops came apart: a pin joint stands {gap * 1e3:.3g} mm open at the end (over "
                             f"{LOOP_GAP:g} × the crank radius)")
    cpu = time.process_time() - t0
    return _measure(model, m, S_all, X_all, n, K, n_settle, samples, dt, kinematic_travel, cpu)


def _roll(m, d, model, state, n, dt, total, states, sensors, warnings) -> None:
    """Step ``total`` steps from ``state``, one native call per turn, appending each call's states and
    sensor rows; a MuJoCo warning (an unstable simulation, which MuJoCo resets and continues) fails it."""
    import mujoco
    from mujoco import rollout
    done = 0
    while done < total:  # one native call per turn
        step = min(n, total - done)
        k = np.arange(done, done + step)
        ctrl = np.empty((step, m.nu))
        ctrl[:, 0] = model.omega * k * dt  # the servo's reference angle at the start of each step
        ctrl[:, 1] = model.omega
        ctrl[:, 2] = -model.walk * model.drag  # the drag on the body, against the walking direction
        out_state, out_sens = rollout.rollout(m, d, state[None, :], ctrl[None, :, :], nstep=step)
        states.append(out_state[0])
        sensors.append(out_sens[0])
        state = out_state[0, -1].copy()
        done += step
        bad = int(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number)
        if warnings or bad:
            what = warnings[0] if warnings else "Nan, Inf or huge value in QACC"
            raise PhysicsFailure(f"the simulation became unstable (MuJoCo: {' '.join(what.split())}); its legs may "
                                 f"be too light for their stiff loop constraints (give the mechanism its masses)")


#: A pin joint open by more than this × the crank radius at the end of the run fails the design.
LOOP_GAP = 0.01


def _loop_gap(m, d, state) -> float:
    """The widest opening of a loop-closing pin (m) in ``state``: the largest equality-constraint violation."""
    import mujoco
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(m, d)
    ne = int(d.ne)
    return float(np.max(np.abs(d.efc_pos[:ne]))) if ne else 0.0


def _measure(model, m, S_all, X, n, K, n_settle, samples, dt, kinematic_travel, cpu) -> dict:
    """The metrics from the measured states S_all (K·n + 1, nstate) and sensors X (K·n, nsensordata)."""
    import mujoco

    L = model.n_legs
    st = model.settings

    def qpos(name):  # the state is time, then qpos (mjSTATE_FULLPHYSICS order)
        return S_all[:, 1 + m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]]

    x, z = qpos("body_x"), qpos("body_z")
    pitch = qpos("body_pitch") if st.pitch == "free" else np.zeros_like(x)
    travel = model.walk * (x[-1] - x[0]) / K
    tau = X[:, 0] + X[:, 1]
    feet = X[:, 2:2 + 10 * L].reshape(-1, L, 10)
    found = feet[:, :, 0] > 0
    fx, fz = feet[:, :, 1], feet[:, :, 3]
    rho = st.foot_radius * model.crank_radius
    slip = feet[:, :, 4] - rho * feet[:, :, 8]  # the foot sphere's lowest point: v_x − ρ·Ω_y
    normal = np.where(found, np.abs(fz), 0.0)
    friction_work = float(np.sum(np.where(found, np.abs(fx * slip), 0.0)) * dt / K)
    per = n // samples
    after = (n_settle + np.arange(1, K * n + 1)) % n  # crank-angle index (of n per turn) after each step
    at_sample = after % per == 0  # the steps that end at θ_k = 2πk/S
    loaded = normal > st.loaded * model.weight
    loaded_max = int(loaded[at_sample].sum(axis=1).max())
    # the servo torque of a step acts from its start; phase-average it by the sample its start lies in
    start_bin = ((after - 1) % n) // per
    tau_bar = np.bincount(start_bin, weights=tau, minlength=samples) / np.bincount(start_bin, minlength=samples)
    win = max(1, int(round(st.impact_window / (2.0 * math.pi) * n)))
    impact = math.nan
    for j in range(L):  # the largest normal force within the window after each landing
        c = found[:, j]
        for i in np.flatnonzero(c[1:] & ~c[:-1]) + 1:
            peak = float(normal[i:i + win, j].max())
            impact = peak if not math.isfinite(impact) else max(impact, peak)
    out = {"physics_travel": float(travel), "physics_bob": float(np.ptp(z)), "physics_pitch": float(np.ptp(pitch)),
           "physics_loaded_feet_max": float(loaded_max), "physics_friction_work": friction_work,
           "physics_torque_peak": float(np.max(np.abs(tau_bar))), "physics_torque_rms": float(np.sqrt(np.mean(tau_bar ** 2))),
           "physics_impact_peak": impact,
           "physics_travel_diff": (100.0 * (travel - kinematic_travel) / kinematic_travel
                                   if kinematic_travel else math.nan),
           "cpu_s": cpu}
    end_bin = after // per
    nb = np.bincount(end_bin, minlength=samples)
    out["series"] = {"torque": tau_bar,
                     "normal": np.stack([np.bincount(end_bin, weights=normal[:, j], minlength=samples) / nb
                                         for j in range(L)], axis=1),
                     "height": z[1:][at_sample], "pitch": pitch[1:][at_sample],
                     "loaded": loaded[at_sample].sum(axis=1)}
    return out


def check_design(mech, P, V, walker, operating, settings: Settings, samples: int,
                 kinematic_travel: float | None = None) -> dict:
    """Build and run one design's model: :func:`build_model` then :func:`run_model`."""
    model = build_model(mech, P, V, walker, operating, settings)
    out = run_model(model, samples, kinematic_travel)
    out["massless"] = model.massless
    out["mass"] = model.mass
    return out
