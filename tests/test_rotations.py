"""Orientation paths and the spherical wrist (seed 004, problem 1; issue 30): against plain numpy references.

References written here: rotation matrices from cos/sin, the geodesic angle arccos((tr − 1)/2) (and its
small-angle-safe chord form 2·asin(‖A − B‖_F / 2√2)), Rodrigues' formula for the geodesic, Z-Y-X angles
read off the matrix by hand, the quintic law by hand, finite-difference rates.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from explorer.cli import main
from explorer.wrist import (INTERPOLATIONS, SEQUENCES, check_sequence, euler_sets, interpolate, orthonormality_defect,
                            track, wrist_path)

D = math.radians


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=float)


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=float)


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=float)


AXIS = {"X": rx, "Y": ry, "Z": rz}


def intrinsic(seq, q):
    """R = R_seq[0](q0)·R_seq[1](q1)·R_seq[2](q2) (upper-case sequence: rotations about the moving axes)."""
    return AXIS[seq[0]](q[0]) @ AXIS[seq[1]](q[1]) @ AXIS[seq[2]](q[2])


def geodesic(A, B):
    """Angle of AᵀB from its trace, degrees."""
    return math.degrees(math.acos(np.clip((np.trace(A.T @ B) - 1.0) / 2.0, -1.0, 1.0)))


def chord_angle(A, B):
    """Angle between rotations A and B (radians) from ‖A − B‖_F = 2√2 sin(θ/2), accurate at small θ."""
    return 2.0 * np.arcsin(np.clip(np.linalg.norm(A - B, axis=(-2, -1)) / (2.0 * math.sqrt(2.0)), 0.0, 1.0))


def rodrigues(k, th):
    k = np.asarray(k, dtype=float) / np.linalg.norm(k)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * Kx + (1 - math.cos(th)) * Kx @ Kx


def quintic(tau):
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


SEED_R = rz(D(45)) @ ry(D(30)) @ rz(D(20))


def zyx_by_hand(R):
    """(φ, θ, ψ) of R = Rz(φ)·Ry(θ)·Rx(ψ), principal set (θ in [−90°, 90°])."""
    return np.array([math.atan2(R[1, 0], R[0, 0]), -math.asin(np.clip(R[2, 0], -1, 1)), math.atan2(R[2, 1], R[2, 2])])


# -- the seed's numbers -----------------------------------------------------------------------------
def test_seed_rotation_and_its_printed_matrix():
    printed = np.array([[0.3336, -0.8379, 0.3536], [0.8173, 0.4550, 0.3536], [-0.4698, 0.1710, 0.8660]])
    err = np.abs(SEED_R - printed)
    assert err[0, 1] > 0.03  # the seed's R12 typo: the product is -0.8739
    assert round(SEED_R[0, 1], 4) == -0.8739
    err[0, 1] = 0.0
    assert err.max() < 5e-5  # every other element to the seed's 4 decimals


def test_seed_euler_sets_to_printed_precision():
    sets = np.degrees(euler_sets(SEED_R[None], "ZYX")[0])  # (2, 3): (φ, θ, ψ) each
    phi, theta, psi = sets[0]
    assert (round(theta, 2), round(psi, 2), round(phi, 1)) == (28.02, 11.17, 67.8)
    phi2, theta2, psi2 = np.mod(sets[1], 360.0)
    assert (round(theta2, 2), round(psi2, 2), round(phi2, 1)) == (151.98, 191.17, 247.8)
    for q in sets:  # the convention that reproduces them: R = Rz(φ)·Ry(θ)·Rx(ψ)
        assert np.abs(rz(D(q[0])) @ ry(D(q[1])) @ rx(D(q[2])) - SEED_R).max() < 1e-12
    assert np.allclose(np.radians(sets[0]), zyx_by_hand(SEED_R), atol=1e-12)


@pytest.mark.parametrize("seq", SEQUENCES)
def test_both_sets_are_the_same_rotation_in_every_sequence(seq):
    rng = np.random.default_rng(3)
    for _ in range(5):
        R = intrinsic("ZYX", rng.uniform(-3, 3, 3))
        both = euler_sets(R[None], seq)[0]
        assert not np.allclose(both[0], both[1])
        for q in both:
            assert np.abs(intrinsic(seq, q) - R).max() < 1e-12
        mid = both[0][1]
        assert (0.0 <= mid <= math.pi) if seq[0] == seq[2] else (-math.pi / 2 <= mid <= math.pi / 2)


def test_issue_facts_matrix_midpoint_det_and_euler_sweep():
    mid = interpolate(np.stack([np.eye(3), rz(D(90))]), np.array([0.5]), "matrix")[0]
    assert np.allclose(mid, 0.5 * (np.eye(3) + rz(D(90))), atol=1e-15)
    assert abs(np.linalg.det(mid) - 0.5) < 1e-15
    frob, det = orthonormality_defect(mid)
    assert abs(frob - np.linalg.norm(mid.T @ mid - np.eye(3))) < 1e-15 and abs(det + 0.5) < 1e-15
    # Euler Z-Y-X 0 -> 90° on all three axes: 116.4° swept for a 90° geodesic
    end = rz(D(90)) @ ry(D(90)) @ rx(D(90))
    assert abs(geodesic(np.eye(3), end) - 90.0) < 1e-9
    s = np.linspace(0, 1, 2001)
    R = interpolate(np.stack([np.eye(3), end]), s, "euler", euler_seq="ZYX", euler_given=[None, np.radians([90, 90, 90])])
    by_hand = np.array([rz(D(90 * x)) @ ry(D(90 * x)) @ rx(D(90 * x)) for x in s])
    assert np.abs(R - by_hand).max() < 1e-12
    swept = math.degrees(chord_angle(by_hand[:-1], by_hand[1:]).sum())
    assert 116.3 < swept < 116.5
    w = wrist_path(np.stack([np.eye(3), end]), "euler", steps=2001, wrist="ZYX",
                   euler_given=[None, np.radians([90, 90, 90])], timing_law="linear")
    assert abs(math.degrees(w.path_angle) - swept) < 1e-6 and abs(math.degrees(w.geodesic_angle) - 90.0) < 1e-9


# -- the methods against plain references -----------------------------------------------------------
def test_slerp_axis_angle_and_spline_are_the_geodesic_from_identity():
    k = np.array([SEED_R[2, 1] - SEED_R[1, 2], SEED_R[0, 2] - SEED_R[2, 0], SEED_R[1, 0] - SEED_R[0, 1]])
    th = math.acos((np.trace(SEED_R) - 1) / 2)
    s = np.linspace(0, 1, 11)
    ref = np.array([rodrigues(k, x * th) for x in s])
    assert np.abs(ref[-1] - SEED_R).max() < 1e-12
    for method in ("slerp", "axis-angle", "spline"):
        assert np.abs(interpolate(np.stack([np.eye(3), SEED_R]), s, method) - ref).max() < 1e-12, method


def test_matrix_and_euler_paths_by_hand():
    K = np.stack([np.eye(3), SEED_R])
    s = np.array([0.2, 0.6])
    M = interpolate(K, s, "matrix")
    assert np.allclose(M, [(1 - x) * np.eye(3) + x * SEED_R for x in s], atol=1e-15)
    set1 = zyx_by_hand(SEED_R)
    E = interpolate(K, s, "euler", euler_seq="ZYX")
    assert np.allclose(E, [rz(x * set1[0]) @ ry(x * set1[1]) @ rx(x * set1[2]) for x in s], atol=1e-14)
    set2 = np.radians([247.8, 151.98, 191.17])  # the seed's set 2, literal: from (0, 0, 0) to it
    E2 = interpolate(K, s, "euler", euler_seq="ZYX", euler_given=[np.zeros(3), set2])
    assert np.allclose(E2, [rz(x * set2[0]) @ ry(x * set2[1]) @ rx(x * set2[2]) for x in s], atol=1e-14)
    # the first keyframe in set 2: I is (180°, 180°, 180°) in Z-Y-X; the end is then reached the shortest way
    E3 = interpolate(K, np.array([0.0, 1.0]), "euler", euler_seq="ZYX", euler_set=2)
    assert np.abs(E3[0] - np.eye(3)).max() < 1e-12 and np.abs(E3[1] - SEED_R).max() < 1e-12
    assert geodesic(E[1], E2[1]) > 10.0  # the seed's claim that set 2 renders the same frames does not hold
    xyz = np.array([math.atan2(-SEED_R[1, 2], SEED_R[2, 2]), math.asin(SEED_R[0, 2]), math.atan2(-SEED_R[0, 1], SEED_R[0, 0])])
    X = interpolate(K, s, "euler", euler_seq="XYZ")
    assert np.allclose(X, [rx(x * xyz[0]) @ ry(x * xyz[1]) @ rz(x * xyz[2]) for x in s], atol=1e-14)


def test_wrist_path_accuracy_columns_by_hand():
    K = np.stack([np.eye(3), SEED_R])
    w = wrist_path(K, "euler", steps=201, wrist="ZYX", timing_law="quintic", duration=10.0)
    t = np.linspace(0, 10, 201)
    assert np.allclose(w.s, quintic(t / 10), atol=1e-15)
    q1 = zyx_by_hand(SEED_R)
    th = math.acos((np.trace(SEED_R) - 1) / 2)
    k = np.array([SEED_R[2, 1] - SEED_R[1, 2], SEED_R[0, 2] - SEED_R[2, 0], SEED_R[1, 0] - SEED_R[0, 1]])
    for i in (40, 100, 170):
        x = quintic(t[i] / 10)
        E = rz(x * q1[0]) @ ry(x * q1[1]) @ rx(x * q1[2])
        assert abs(math.degrees(w.geodesic_deviation[i]) - geodesic(E, rodrigues(k, x * th))) < 1e-6
    assert np.abs(w.defect_frob).max() < 1e-14
    m = wrist_path(K, "matrix", steps=201, wrist="ZYX")
    x = m.s[100]
    A = (1 - x) * np.eye(3) + x * SEED_R
    assert abs(m.defect_frob[100] - np.linalg.norm(A.T @ A - np.eye(3))) < 1e-14
    assert abs(m.defect_det[100] - (np.linalg.det(A) - 1)) < 1e-14
    sl = wrist_path(K, "slerp", steps=201, wrist="ZYX")
    assert sl.ripple < 1e-6 and m.ripple > 0.1 and w.ripple > 0.01
    assert abs(sl.path_angle - th) < 1e-9 and w.path_angle > th + 1e-3


def test_wrist_angles_and_rates_against_finite_differences():
    K = np.stack([np.eye(3), SEED_R])
    w = wrist_path(K, "slerp", steps=2001, wrist="ZYX", timing_law="quintic", duration=10.0)
    ref = np.array([zyx_by_hand(R) for R in w.R])
    assert np.abs(w.angles - ref).max() < 1e-12
    fd = np.gradient(ref, w.t, axis=0)
    assert np.abs(w.rates - fd)[5:-5].max() < 1e-5 * np.abs(fd).max()
    assert np.abs(w.rates[[0, -1]]).max() < 1e-9  # rest to rest
    assert set(w.sets) == {1} and not w.locks


def test_branch_two_is_tracked_without_jumps():
    K = np.stack([np.eye(3), SEED_R])
    w = wrist_path(K, "slerp", steps=501, wrist="ZYX", branch=2)
    assert set(w.sets) == {2}
    assert np.abs(np.diff(w.angles, axis=0)).max() < D(1.0)
    for R, q in zip(w.R[::50], w.angles[::50]):
        assert np.abs(rz(q[0]) @ ry(q[1]) @ rx(q[2]) - R).max() < 1e-12
    end = np.degrees(w.angles[-1])
    assert np.allclose(np.mod(end, 360), [247.8, 151.98, 191.17], atol=0.01)


# -- gimbal lock --------------------------------------------------------------------------------------
def test_pitch_through_lock_is_tracked_and_flagged():
    """Ry(60°) -> Ry(100°): the Z-Y-X wrist's pitch passes 90° (lock) at s = 0.75; the branch is followed
    across (set 1 to set 2), never a 180° jump of yaw and roll; the lock's time inverts the quintic law."""
    K = np.stack([ry(D(60)), ry(D(100))])
    w = wrist_path(K, "slerp", steps=1000, wrist="ZYX", timing_law="quintic", duration=10.0)
    pitch = 60 + 40 * quintic(w.t / 10)
    assert np.abs(np.degrees(w.angles[:, 1]) - pitch).max() < 1e-6
    assert np.abs(w.angles[:, [0, 2]]).max() < 1e-6  # yaw and roll stay 0: no jump
    assert len(w.locks) == 1
    lock = w.locks[0]
    lo, hi = 0.0, 10.0
    for _ in range(80):  # t with quintic(t/10) = 0.75, by bisection
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if quintic(mid / 10) < 0.75 else (lo, mid)
    assert abs(lock.t - lo) < 1e-5 and abs(lock.s - 0.75) < 1e-7
    assert lock.distance < 1e-6 and abs(math.degrees(lock.middle) - 90.0) < 0.05
    assert lock.sets == (1, 2)
    assert lock.t_from < lock.t < lock.t_to
    assert "gimbal lock at t = " in str(lock)
    assert w.sets[0] == 1 and w.sets[-1] == 2


def test_zyz_wrist_at_identity_is_flagged_at_the_start():
    w = wrist_path(np.stack([np.eye(3), SEED_R]), "slerp", steps=201, wrist="ZYZ")
    assert w.locks and w.locks[0].t == 0.0 and w.locks[0].distance < 1e-9
    final = w.angles[-1]
    assert np.abs(rz(final[0]) @ ry(final[1]) @ rz(final[2]) - SEED_R).max() < 1e-12
    assert abs(math.degrees(final[1]) - 30.0) < 1e-9


def test_track_keeps_yaw_continuous_at_exact_lock():
    """A yaw-only turn at pitch exactly 90°: only yaw − roll is defined; the tracker keeps yaw (q1) at its
    start and puts the turn into roll, continuously."""
    R = np.array([rz(D(10)) @ ry(D(90)) @ rx(D(10 + a)) for a in np.linspace(0, 50, 51)])
    q, sets = track(R, "ZYX", start=np.radians([10, 90, 10]))
    assert np.abs(np.diff(q, axis=0)).max() < D(1.5)
    for Ri, qi in zip(R, q):
        assert np.abs(rz(qi[0]) @ ry(qi[1]) @ rx(qi[2]) - Ri).max() < 1e-9


# -- bad input ----------------------------------------------------------------------------------------
def test_bad_sequence_and_method_are_refused():
    for bad in ("ZZY", "ZYx", "ZY", "ABC", 3):
        with pytest.raises(ValueError, match="Euler sequence"):
            check_sequence(bad)
    with pytest.raises(ValueError, match="interpolation: expected one of"):
        interpolate(np.stack([np.eye(3)] * 2), [0.5], "lerp")
    assert set(INTERPOLATIONS) == {"slerp", "spline", "matrix", "euler", "axis-angle"}
    K = np.stack([np.eye(3), SEED_R])
    for kw, match in (({"euler_set": 0}, "euler_set"), ({"branch": 3}, "branch"), ({"steps": 2}, "steps"),
                      ({"lock_tolerance": 0.0}, "lock_tolerance"), ({"wrist": "XXY"}, "Euler sequence"),
                      ({"timing_law": "cubic"}, "timing")):
        with pytest.raises(ValueError, match=match):
            wrist_path(K, "euler", **kw)


# -- the bench verb -----------------------------------------------------------------------------------
def test_cli_bench_rotations(tmp_path, capsys):
    png, csv = tmp_path / "rotations.png", tmp_path / "r.csv"
    assert main(["bench", "rotations", "--steps", "41", "--samples", "20", "--repeat", "1", "-o", str(png),
                 "--csv", str(csv), "--methods", "matrix,euler ZYX set 2"]) == 0
    out = capsys.readouterr().out
    assert "theta = 28.02°, psi = 11.17°, phi = 67.80°" in out
    assert "theta = 151.98°, psi = 191.17°, phi = 247.80°" in out
    assert "det = 0.5000" in out and "sweeps 116.43°" in out
    # linear on Z-Y-X from (0, 0, 0) to the seed's set 2: the pitch 151.98°·t/10 s passes 90° (lock) at t = 5.922 s
    assert f"euler ZYX set 2: gimbal lock at t = {10 * 90 / 151.98:.4g} s" in out
    rows = csv.read_text().splitlines()
    assert rows[0].startswith("row,defect_frob") and [r.split(",")[0] for r in rows[1:]] == [
        "slerp", "matrix", "euler ZYX set 2"]
    assert float(rows[2].split(",")[1]) > 0.4  # the element-wise path's ||R^T R - I|| (0.476 here)
    import matplotlib.image as mpimg

    img = mpimg.imread(png)[..., :3]
    # the six frames' trplot colours: r, g, b, m, c, k (matplotlib's single-letter colours)
    for rgb in ((1, 0, 0), (0, 0.5, 0), (0, 0, 1), (0.75, 0, 0.75), (0, 0.75, 0.75), (0, 0, 0)):
        near = (np.abs(img - np.array(rgb)).max(axis=-1) < 0.08).sum()
        assert near > 200, rgb
    assert main(["bench", "rotations", "--steps", "2"]) == 2
    assert main(["bench", "rotations", "-o", str(png)]) == 2  # exists: needs --force
    assert main(["bench", "rotations", "--methods", "slerp,nope"]) == 2
    err = capsys.readouterr().err
    assert "--steps: expected an integer >= 3" in err and "--force" in err and "Traceback" not in err
    assert "--methods: unknown 'nope'" in err


# -- the arm's wrist: [driver] orientation ------------------------------------------------------------
ARM_WRIST = '''name = "armw"
foot = "T"
[driver]
vertex = "T"
path = "line"
start = [-1.0, 1.0]
end = [2.0, 1.0]
duration = 10.0
timing = "quintic"
{orientation}
[fixed]
O = [0.0, 0.0]
[guess]
E = [-0.6, 1.9]
[[links]]
a = "O"
b = "E"
length = 2.0
[[links]]
a = "E"
b = "T"
length = 1.0
'''


def _arm(tmp_path, orientation, name="armw.toml"):
    from explorer.mechanism import load_mechanism

    path = tmp_path / name
    path.write_text(ARM_WRIST.format(orientation=orientation))
    return load_mechanism(path), path


def test_arm_builtin_wrist_reaches_the_seed_sets_on_both_branches(tmp_path):
    from explorer.kernels import simulate
    from explorer.wrist import wrist_for
    from explorer.mechanism import load_mechanism, mechanism_from_dict, mechanism_toml, parse_toml

    arm = load_mechanism("arm")
    o = arm.path.orientation
    assert o.wrist == "ZYX" and o.interpolation == "slerp" and np.abs(o.matrices()[1] - SEED_R).max() < 1e-12
    w = wrist_for(arm, steps=201)
    assert np.allclose(w.t, simulate(arm, steps=201).theta, atol=1e-15)  # the arm's own samples
    assert np.allclose(w.angles[-1], zyx_by_hand(SEED_R), atol=1e-12) and set(w.sets) == {1}
    back = mechanism_from_dict(parse_toml(mechanism_toml(arm), "x"), "x")
    assert back.path == arm.path
    m, _ = _arm(tmp_path, '''orientation = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]],
    [[0.3336, -0.8739, 0.3536], [0.8173, 0.4550, 0.3536], [-0.4698, 0.1710, 0.8660]]]
interpolation = "euler"
wrist = "ZYX"
wrist_branch = 2''')
    w2 = wrist_for(m, steps=101)
    assert set(w2.sets) == {2}
    assert np.allclose(np.mod(np.degrees(w2.angles[-1]), 360), [247.8, 151.98, 191.17], atol=0.01)
    assert np.abs(np.diff(w2.angles, axis=0)).max() < D(3)
    m3, _ = _arm(tmp_path, 'orientation = [{axis = [0, 1, 0], angle = 60}, {euler = [1.7453292519943295, 0, 0], '
                           'seq = "YXZ", degrees = false}]\nwrist = "ZYX"', "m3.toml")
    w3 = wrist_for(m3, steps=101)
    assert np.allclose(w3.R[0], ry(D(60)), atol=1e-12) and np.allclose(w3.R[-1], ry(D(100)), atol=1e-12)
    assert len(w3.locks) == 1 and abs(w3.locks[0].s - 0.75) < 1e-6  # pitch passes 90°: flagged
    assert mechanism_from_dict(parse_toml(mechanism_toml(m3), "y"), "y").path == m3.path


@pytest.mark.parametrize("orientation, key, value", [
    ('orientation = [{euler = [0, 0, 0], seq = "ZYZ"}, {euler = [1, 2, 3], seq = "ZZY"}]',
     "driver.orientation[1].seq", "'ZZY'"),
    ('orientation = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 0, 0], [0, 1, 0], [0, 0.5, 1]]]',
     "driver.orientation[1]", "not a rotation matrix"),
    ('orientation = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]]',
     "driver.orientation[1]", "det = -1"),
    ('orientation = [{axis = [0, 0, 1], angle = 0}, {axis = [0, 0, 1], angle = 90}]\ninterpolation = "lerp"',
     "driver.interpolation", "'lerp'"),
    ('orientation = [{axis = [0, 0, 1], angle = 0}, {axis = [0, 0, 1], angle = 90}]\nwrist = "zyz"',
     "driver.wrist", "'zyz'"),
    ('orientation = [{axis = [0, 0, 1], angle = 0}, {axis = [0, 0, 0], angle = 90}]', "driver.orientation[1].axis",
     "[0, 0, 0]"),
    ('orientation = [{axis = [0, 0, 1], angle = 0}]', "driver.orientation", "two or more"),
    ('orientation = [{axis = [0, 0, 1], angle = 0}, {axis = [0, 0, 1], angle = 9}]\nwrist_branch = 3',
     "driver.wrist_branch", "3"),
    ('interpolation = "slerp"', "driver.interpolation", "only used with driver.orientation"),
])
def test_bad_orientation_is_one_line_naming_file_key_value(tmp_path, capsys, orientation, key, value):
    from explorer.errors import UserError

    path = tmp_path / "bad.toml"
    path.write_text(ARM_WRIST.format(orientation=orientation))
    from explorer.mechanism import load_mechanism

    with pytest.raises(UserError) as e:
        load_mechanism(path)
    msg = str(e.value)
    assert str(path) in msg and key in msg and value in msg and "\n" not in msg
    assert main(["describe", str(path)]) == 2
    err = capsys.readouterr().err
    assert key in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_cli_bench_rotations_on_the_arm_writes_its_wrist(tmp_path, capsys):
    out = tmp_path / "wrist.csv"
    assert main(["bench", "rotations", "--mechanism", "arm", "--steps", "201", "--samples", "20", "--repeat", "1",
                 "--methods", "euler", "--wrist-method", "euler", "--wrist-csv", str(out)]) == 0
    text = capsys.readouterr().out
    assert "mechanism arm: 2 orientation keyframes over 10 s, wrist ZYX from branch 1" in text
    assert "quintic timing" in text
    rows = out.read_text().splitlines()
    head = rows[0].split(",")
    data = np.array([[float(x) for x in r.split(",")] for r in rows[1:]])
    assert head[:5] == ["t_s", "s", "q1_rad", "q2_rad", "q3_rad"] and data.shape == (201, len(head))
    t, q, rates = data[:, 0], data[:, 2:5], data[:, 5:8]
    assert np.allclose(t, np.linspace(0, 10, 201), atol=1e-12)
    set1 = zyx_by_hand(SEED_R)
    for i in (0, 50, 120, 200):  # linear on the Z-Y-X angles of set 1, timed by the quintic law
        x = quintic(t[i] / 10)
        assert np.allclose(q[i], x * set1, atol=1e-12)
    fd = np.gradient(q, t, axis=0)
    assert np.abs(rates - fd)[3:-3].max() < 1e-3 * np.abs(fd).max()
    assert main(["bench", "rotations", "--mechanism", "jansen"]) == 2
    assert "no [driver] orientation" in capsys.readouterr().err


def test_describe_shows_the_wrist_and_its_gimbal_lock(tmp_path, capsys):
    _, path = _arm(tmp_path, 'orientation = [{axis = [0, 1, 0], angle = 60}, {axis = [0, 1, 0], angle = 100}]\n'
                             'wrist = "ZYX"\ninterpolation = "axis-angle"')
    assert main(["describe", str(path)]) == 0
    out = capsys.readouterr().out
    lo, hi = 0.0, 10.0
    for _ in range(80):  # pitch 60° + 40°·s(t) reaches 90° at s = 0.75 of the quintic law
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if quintic(mid / 10) < 0.75 else (lo, mid)
    assert "wrist: spherical, joints ZYX (branch 1), axis-angle through 2 keyframes" in out
    assert f"wrist: gimbal lock at t = {lo:.4g} s (s = 0.75)" in out and "from set 1 to set 2" in out
    assert main(["describe", str(path), "--format", "json"]) == 0
    import json

    w = json.loads(capsys.readouterr().out)["driver"]["wrist"]
    assert abs(w["gimbal_locks"][0]["t"] - lo) < 1e-5 and np.allclose(w["end_deg"], [0, 100, 0], atol=1e-9)


def _omega_by_hand(A, B, h):
    """Body angular velocity (3,) from A to B over h: the axis-angle of AᵀB from its skew part and trace."""
    M = A.T @ B
    th = math.acos(np.clip((np.trace(M) - 1) / 2, -1, 1))
    v = np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]]) / 2
    return v / math.sin(th) * th / h if th > 0 else np.zeros(3)


def test_spline_through_three_keyframes_has_a_continuous_angular_rate():
    K = np.stack([np.eye(3), rz(D(80)) @ ry(D(20)), rz(D(90)) @ rx(D(70))])
    h = 1e-5
    for method, continuous in (("spline", True), ("slerp", False)):
        R = interpolate(K, np.array([0.0, 0.5, 1.0]), method)
        assert np.abs(R - K).max() < 1e-12  # through every keyframe
        a = interpolate(K, np.array([0.5 - 2 * h, 0.5 - h, 0.5, 0.5 + h, 0.5 + 2 * h]), method)
        # the body angular velocity just before and just after the middle keyframe, in the keyframe's frame
        before = _omega_by_hand(a[1], a[2], h)
        after = _omega_by_hand(a[2], a[3], h)
        jump = np.linalg.norm(after - before) / np.linalg.norm(after)
        assert (jump < 1e-3) if continuous else (jump > 0.1), (method, jump)
