#!/usr/bin/python3
"""Generates the camera-model reference data of tests/test_camera.c.

Run from the repository root:  /usr/bin/python3 tests/data/ocam/make_fixtures.py
Needs python3-opencv and python3-numpy (Debian), only to regenerate; the test
itself uses the pasted output.

- Pinhole and equidistant references come from OpenCV itself
  (cv2.projectPoints, cv2.fisheye.projectPoints), not from mocapd's formulas.
- The ocam references follow OCamCalib's own C code (ocam_functions.c:
  cam2world, world2cam) in the toolbox's conventions: pixels as (row, column),
  its own 3D axes, polynomials as read from calib_results.txt.
- Writes tests/data/ocam/asym_calib_results.txt (an off-centre lens with a
  non-trivial affine part) and tests/data/ocam/ego_calib_results.txt (the lens
  of ../shared/data/ego/*/calib.json in OCamCalib's layout), both in the exact
  layout of OCamCalib's export (MATLAB export_data.m: %e for the direct
  polynomial, %f for the rest, blank lines between sections).
Prints the C tables to paste into tests/test_camera.c.
"""
import math
import os

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
rng = np.random.default_rng(20240611)


def c_row(vals):
    return "\t{" + ", ".join("%.17g" % v for v in vals) + "},"


def directions(n, max_deg):
    """Random unit directions within max_deg of +z (uniform in angle)."""
    out = []
    for _ in range(n):
        t = math.radians(max_deg) * rng.random()
        a = 2 * math.pi * rng.random()
        out.append((math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)))
    return np.array(out)


def pinhole():
    K = np.array([[512.3, 0, 321.4], [0, 509.8, 238.9], [0, 0, 1.0]])
    D = np.array([-0.281, 0.093, 0.0012, -0.0007, -0.011])  # k1 k2 p1 p2 k3
    P = directions(40, 44) * rng.uniform(0.5, 5.0, (40, 1))
    uv, _ = cv2.projectPoints(P.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    print("/* cv2.projectPoints (OpenCV %s): fx 512.3 fy 509.8 cx 321.4 cy 238.9,"
          " k1 k2 p1 p2 k3 = -0.281 0.093 0.0012 -0.0007 -0.011; X Y Z u v */" % cv2.__version__)
    print("static const double pinhole_ref[][5] = {")
    for p, q in zip(P, uv.reshape(-1, 2)):
        if -0.5 <= q[0] < 639.5 and -0.5 <= q[1] < 479.5:
            print(c_row([*p, *q]))
    print("};")


def fisheye():
    K = np.array([[331.7, 0, 641.3], [0, 330.9, 479.2], [0, 0, 1.0]])
    D = np.array([0.021, -0.0063, 0.0012, -0.00018])
    P = directions(40, 89) * rng.uniform(0.5, 5.0, (40, 1))
    uv, _ = cv2.fisheye.projectPoints(P.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    print("/* cv2.fisheye.projectPoints (OpenCV %s): fx 331.7 fy 330.9 cx 641.3 cy 479.2,"
          " k1..k4 = 0.021 -0.0063 0.0012 -0.00018, 1280x960; X Y Z u v */" % cv2.__version__)
    print("static const double fisheye_ref[][5] = {")
    for p, q in zip(P, uv.reshape(-1, 2)):
        if -0.5 <= q[0] < 1279.5 and -0.5 <= q[1] < 959.5:
            print(c_row([*p, *q]))
    print("};")


# ---- OCamCalib ----------------------------------------------------------

def write_calib_results(path, pol, invpol, xc, yc, c, d, e, height, width):
    """The layout of OCamCalib's export_data.m, byte for byte."""
    with open(path, "w") as f:
        f.write("#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
                "These are used by cam2world\n\n")
        f.write("%d " % len(pol))
        for a in pol:
            f.write("%e " % a)
        f.write("\n\n")
        f.write("#polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). "
                "These are used by world2cam\n\n")
        f.write("%d " % len(invpol))
        for a in invpol:
            f.write("%f " % a)
        f.write("\n\n")
        f.write('#center: "row" and "column", starting from 0 (C convention)\n\n')
        f.write("%f %f\n\n" % (xc, yc))
        f.write('#affine parameters "c", "d", "e"\n\n')
        f.write("%f %f %f\n\n" % (c, d, e))
        f.write('#image size: "height" and "width"\n\n')
        f.write("%d %d\n\n" % (height, width))


def read_calib_results(path):
    """Reads the numbers back, as the toolbox's get_ocam_model does."""
    nums = []
    for line in open(path):
        if line.startswith("#"):
            continue
        nums += line.split()
    it = iter(nums)
    pol = [float(next(it)) for _ in range(int(next(it)))]
    invpol = [float(next(it)) for _ in range(int(next(it)))]
    xc, yc = float(next(it)), float(next(it))
    c, d, e = (float(next(it)) for _ in range(3))
    height, width = int(next(it)), int(next(it))
    return dict(pol=pol, invpol=invpol, xc=xc, yc=yc, c=c, d=d, e=e, height=height, width=width)


def cam2world(m, row, col):
    """ocam_functions.c cam2world: (row, col) -> unit vector, toolbox axes."""
    invdet = 1 / (m["c"] - m["d"] * m["e"])
    xp = invdet * ((row - m["xc"]) - m["d"] * (col - m["yc"]))
    yp = invdet * (-m["e"] * (row - m["xc"]) + m["c"] * (col - m["yc"]))
    r = math.sqrt(xp * xp + yp * yp)
    zp = m["pol"][0]
    r_i = 1.0
    for a in m["pol"][1:]:
        r_i *= r
        zp += r_i * a
    n = math.sqrt(xp * xp + yp * yp + zp * zp)
    return xp / n, yp / n, zp / n


def world2cam(m, p):
    """ocam_functions.c world2cam: toolbox-axes point -> (row, col)."""
    norm = math.sqrt(p[0] * p[0] + p[1] * p[1])
    theta = math.atan(p[2] / norm)
    rho = m["invpol"][0]
    t_i = 1.0
    for a in m["invpol"][1:]:
        t_i *= theta
        rho += t_i * a
    x = p[0] / norm * rho
    y = p[1] / norm * rho
    return x * m["c"] + y * m["d"] + m["xc"], x * m["e"] + y + m["yc"]


def fit_invpol(pol, theta_lo, theta_hi, rho_max, degree):
    """rho(theta) with theta = atan(w/rho) as world2cam measures it."""
    rho = np.linspace(1e-3, rho_max, 4000)
    w = np.polynomial.polynomial.polyval(rho, pol)
    theta = np.arctan(w / rho)
    keep = (theta >= theta_lo) & (theta <= theta_hi)
    coef = np.polynomial.polynomial.polyfit(theta[keep], rho[keep], degree)
    return coef


def invpol_error(m, max_theta):
    """Largest world2cam - exact pixel error over the field, pixels."""
    worst = 0.0
    for i in range(1, 400):
        # rays at three azimuths, out from the centre
        rho = i
        w = np.polynomial.polynomial.polyval(rho, m["pol"])
        if math.atan2(rho, -w) > max_theta:
            break
        for ang in (0.3, 1.9, 4.0):
            xp, yp = rho * math.cos(ang), rho * math.sin(ang)
            row = m["c"] * xp + m["d"] * yp + m["xc"]
            col = m["e"] * xp + yp + m["yc"]
            r2, c2 = world2cam(m, (xp, yp, w))
            worst = max(worst, math.hypot(r2 - row, c2 - col))
    return worst


def ocam_asym():
    pol = [-190.5, 0.0, 1.9e-3, -2.4e-6, 6.1e-9]
    max_theta = math.radians(95)
    invpol = fit_invpol(pol, -math.pi / 2, max_theta - math.pi / 2 + 0.05, 420, 12)
    path = os.path.join(HERE, "asym_calib_results.txt")
    write_calib_results(path, pol, invpol, 236.42, 322.77, 1.0021, 0.0007, -0.0004, 480, 640)
    m = read_calib_results(path)
    err = invpol_error(m, max_theta)
    print("/* OCamCalib cam2world on asym_calib_results.txt (toolbox axes): row col x y z */")
    print("static const double ocam_cam2world_ref[][5] = {")
    for _ in range(30):
        row, col = rng.uniform(-0.5, 479.5), rng.uniform(-0.5, 639.5)
        x, y, z = cam2world(m, row, col)
        if math.atan2(math.hypot(x, y), -z) <= max_theta:
            print(c_row([row, col, x, y, z]))
    print("};")
    print("/* OCamCalib world2cam (inverse polynomial) on the same file: x y z row col;"
          " its largest error against the exact inverse over the field is %.3g px */" % err)
    print("#define OCAM_INVPOL_ERR_PX %.3g" % (err * 1.5 + 1e-3))
    print("static const double ocam_world2cam_ref[][5] = {")
    for p in directions(20, 94) * rng.uniform(0.5, 5.0, (20, 1)):
        q = (p[1], p[0], -p[2])  # OpenCV axes -> toolbox axes
        row, col = world2cam(m, q)
        if -0.5 <= row < 479.5 and -0.5 <= col < 639.5:
            print(c_row([*q, row, col]))
    print("};")


def ocam_ego():
    """The shared data's lens: w(rho) = a0 + a2 rho^2 + a3 rho^3 + a4 rho^4 in
    OpenCV axes; the toolbox's z points backwards, so its polynomial is -w."""
    a0, a2, a3, a4 = 81.52990483414433, -0.004317285269898635, 6.361321148859789e-06, -8.948906882522099e-08
    pol = [-a0, 0.0, -a2, -a3, -a4]
    invpol = fit_invpol(pol, -math.pi / 2, 0.02, 140, 10)
    path = os.path.join(HERE, "ego_calib_results.txt")
    write_calib_results(path, pol, invpol, 127.5, 127.5, 1.0, 0.0, 0.0, 256, 256)
    m = read_calib_results(path)
    print("/* ego_calib_results.txt: invpol error over 90 deg %.3g px */" % invpol_error(m, math.pi / 2))


if __name__ == "__main__":
    pinhole()
    fisheye()
    ocam_asym()
    ocam_ego()
