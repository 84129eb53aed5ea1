"""How many more vertices triangles of bounded shape need than stretched ones, by the classic error estimate.

For linear interpolation with a vertical error bound, the best triangles of bounded shape need a vertex count
proportional to the integral of |largest principal curvature| (the Hessian's largest |eigenvalue|), the best
stretched ones to the integral of sqrt(|det Hessian|).  Their ratio, on the DEMs of
``benchmarks/quality_vs_peers.py`` smoothed over 2, 4 and 8 cells (interior cells only), says what an angle
bound costs against greedy insertion's slivers before any algorithm is involved.

    python benchmarks/quality_anisotropy.py
"""

from __future__ import annotations

import numpy as np
from quality_vs_peers import DEMS
from scipy import ndimage

import tinsmith


def ratio(hf, sigma: float) -> float:
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    z = ndimage.gaussian_filter(np.where(np.isnan(z), np.nanmean(z), z), sigma)
    zy, zx = np.gradient(z)
    zyy, zyx = np.gradient(zy)
    zxy, zxx = np.gradient(zx)
    b = 0.5 * (zxy + zyx)
    half_trace, det = 0.5 * (zxx + zyy), zxx * zyy - b * b
    root = np.sqrt(np.maximum(half_trace**2 - det, 0.0))
    l1, l2 = half_trace + root, half_trace - root
    inner = ndimage.binary_erosion(hf.valid, iterations=int(3 * sigma))
    return float(np.maximum(abs(l1), abs(l2))[inner].sum() / np.sqrt(abs(l1 * l2))[inner].sum())


def main() -> None:
    print("| DEM | sigma 2 | sigma 4 | sigma 8 |\n| --- | --- | --- | --- |")
    for label, path in DEMS:
        if path.exists():
            hf = tinsmith.read_heightfield(path)
            print(f"| {label} | " + " | ".join(f"{ratio(hf, s):.2f}" for s in (2, 4, 8)) + " |")


if __name__ == "__main__":
    main()
