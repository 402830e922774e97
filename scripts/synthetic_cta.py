"""A synthetic CT angiogram for the full-size benchmarks (scripts/read_speed.py,
scripts/fullsize_run.py): int16 Hounsfield units, (z, y, x) as SimpleITK's arrays are."""

from __future__ import annotations

import numpy as np

#: Voxel spacing (x, y, z) mm and origin of the volumes the scripts write.
SPACING = (0.7, 0.7, 0.8)
ORIGIN = (-180.0, -180.0, -400.0)


def aorta_centre(dims, z):
    """The aorta's centre (x, y), in voxels, on slice ``z``."""
    nx, ny, _ = dims
    return nx / 2 + 0.05 * nx * np.sin(z / 80.0), 0.45 * ny


def ct_volume(dims, seed=18):
    """Air at -1000 HU, an elliptic body of soft tissue (40 HU) with a fat rim (-100 HU), an
    aorta of 300 HU winding slowly along z (radius 2.5% of the width), noise of 12 HU."""
    nx, ny, nz = dims
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:ny, 0:nx].astype(np.float32)
    ex, ey = (x - nx / 2) / (0.42 * nx), (y - ny / 2) / (0.33 * ny)
    r = np.sqrt(ex**2 + ey**2)
    plane = np.where(r < 1.0, np.where(r > 0.9, -100.0, 40.0), -1000.0).astype(np.float32)
    volume = np.empty((nz, ny, nx), np.int16)
    for z in range(nz):
        cx, cy = aorta_centre(dims, z)
        aorta = (x - cx) ** 2 + (y - cy) ** 2 < (0.025 * nx) ** 2
        noise = rng.normal(0.0, 12.0, (ny, nx)).astype(np.float32)
        volume[z] = np.clip(np.where(aorta, 300.0, plane) + noise, -1024, 3071)
    return volume
