r"""
Building a response surface on a Dask cluster
=============================================

.. topic:: What you will learn

   * how to run the finite-element runs of a response surface on a Dask cluster by
     passing a ``dask.distributed.Client`` (or ``scheduler="tcp://HOST:PORT"``, the
     CLI's ``--scheduler``) to :meth:`~skin_indent.response_surface.ResponseSurface.build`;
   * that the cluster changes where the runs happen, not their results: the surface
     equals the one built in this process, bit for bit;
   * that every finished run is written to the run cache as it arrives, so a build that
     is interrupted resumes where it stopped.

A ``LocalCluster`` with two worker processes on this machine stands for the cluster a
lab already runs; with a real one, only the ``Client`` line changes
(``Client("tcp://scheduler:8786")``). Dask is an optional extra:
``pip install 'skin_indent[dask]'``.
"""

# %%
# A small grid on the coarse mesh
# -------------------------------
import tempfile
import time
from pathlib import Path

import numpy as np
from distributed import Client, LocalCluster

from skin_indent.response_surface import ResponseSurface, SurfaceGrid, default_settings

grid = SurfaceGrid(depth_mm=np.linspace(0.02, 0.6, 30), E_kPa=np.geomspace(1.0, 100.0, 8),
                   nu=np.linspace(0.3, 0.49, 4))
settings = default_settings(radius_mm=6.22, mesh="coarse")

# %%
# On the cluster, then in this process
# ------------------------------------
# The runs go to the workers as they free up. The block is guarded by
# ``if __name__ == "__main__"`` as Dask recommends: worker processes may re-import the
# script that started them.
cache = Path(tempfile.mkdtemp()) / "cache"
if __name__ == "__main__":  # worker processes re-import this file: start the cluster only once
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        t = time.perf_counter()
        on_cluster = ResponseSurface.build(grid, settings=settings, client=client, cache_dir=cache, progress=False)
        cluster_s = time.perf_counter() - t
    print(f"{grid.nu.size} runs on 2 Dask workers: {cluster_s:.1f} s")

    # The same surface in this process
    t = time.perf_counter()
    here = ResponseSurface.build(grid, settings=settings, workers=1, progress=False)
    local_s = time.perf_counter() - t
    max_difference = float(np.max(np.abs(on_cluster.unit_forces - here.unit_forces)))
    print(f"in this process: {local_s:.1f} s; largest difference of the unit forces: {max_difference:g} mN")

    # The run cache: each run was written, atomically and with its checksum, as it finished; a second
    # build with the same cache computes nothing.
    t = time.perf_counter()
    again = ResponseSurface.build(grid, settings=settings, cache_dir=cache, progress=False)
    print(f"rebuilt from the cache in {time.perf_counter() - t:.2f} s; "
          f"F(0.6 mm; E = 10 kPa, nu = 0.45) = {again.force([0.6], (10.0, 0.45))[0]:.4f} mN")
