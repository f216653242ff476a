#!/usr/bin/python3
"""Writes reference.csv: CIELAB (D65, CIE 1931 2 degree), ITA and the Diffey melanin and
erythema indices of every shipped NIST forearm spectrum, computed with numpy alone from the
CIE tables in data/colour/, for tests/spectral/skin_tone_test.cpp to compare skinspec's own against.

Run with Debian's python3 (python3-numpy): /usr/bin/python3 tests/data/skin-tone/make_reference.py
"""
import csv
import math
import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[3]


def table(path):
    rows = [line for line in path.read_text().splitlines() if line and not line.startswith("#")]
    reader = csv.reader(rows)
    header = next(reader)
    data = np.array([[float(v) for v in row] for row in reader])
    return header, data


def main():
    _, cmf = table(ROOT / "data/colour/cie1931_2deg_cmf.csv")
    ill_header, ill = table(ROOT / "data/colour/cie_illuminants.csv")
    skin_header, skin = table(ROOT / "data/real-skin/nist_forearm_odd_subjects_379-781nm_3nm.csv")
    grid = np.arange(360.0, 830.0 + 0.5, 1.0)
    xbar, ybar, zbar = (np.interp(grid, cmf[:, 0], cmf[:, k]) for k in (1, 2, 3))
    d65 = np.interp(grid, ill[:, 0], ill[:, ill_header.index("D65")])
    k = 1.0 / np.sum(d65 * ybar)
    white = k * np.array([np.sum(d65 * xbar), np.sum(d65 * ybar), np.sum(d65 * zbar)])

    def f(t):
        return np.cbrt(t) if t > (6 / 29) ** 3 else t / (3 * (6 / 29) ** 2) + 4 / 29

    out = ROOT / "tests/data/skin-tone/reference.csv"
    with out.open("w", newline="") as handle:
        handle.write("# Written by make_reference.py beside it (numpy, data/colour/ tables).\n")
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["subject", "L", "a", "b", "ita_deg", "melanin_index", "erythema_index"])
        for column in range(1, skin.shape[1]):
            r = np.interp(grid, skin[:, 0], skin[:, column])
            xyz = k * np.array([np.sum(d65 * r * xbar), np.sum(d65 * r * ybar), np.sum(d65 * r * zbar)])
            fx, fy, fz = (f(xyz[i] / white[i]) for i in range(3))
            lab = (116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz))
            ita = math.degrees(math.atan((lab[0] - 50) / lab[2]))
            red = np.interp(655.0, skin[:, 0], skin[:, column])
            green = np.interp(568.0, skin[:, 0], skin[:, column])
            writer.writerow([skin_header[column], *(f"{v:.6f}" for v in (*lab, ita)),
                             f"{100 * math.log10(1 / red):.6f}", f"{100 * math.log10(red / green):.6f}"])


if __name__ == "__main__":
    main()
