"""docs/dask-jobqueue.yaml builds a SLURMCluster whose job script starts single-threaded workers
in the configured environment (sbatch itself cannot run here: there is no SLURM)."""

from __future__ import annotations

from pathlib import Path

import dask.config
import dask_jobqueue
import yaml

CONFIG = Path(__file__).resolve().parents[2] / "docs" / "dask-jobqueue.yaml"


def test_example_config_builds_a_slurm_cluster():
    config = yaml.safe_load(CONFIG.read_text())
    slurm = config["jobqueue"]["slurm"]
    assert slurm["cores"] == slurm["processes"]  # one single-threaded worker a core
    # As when the file is ~/.config/dask/jobqueue.yaml: its keys over dask-jobqueue's defaults.
    with dask.config.set({f"jobqueue.slurm.{key}": value for key, value in slurm.items()}):
        with dask_jobqueue.SLURMCluster(scheduler_options={"host": "127.0.0.1", "dashboard_address": None}) as cluster:
            script = cluster.job_script()
            assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
    assert "#SBATCH -J durer-worker" in script
    assert "#SBATCH -n 1" in script and f"#SBATCH --cpus-per-task={slurm['cores']}" in script
    assert "#SBATCH -t 04:00:00" in script
    assert "source $HOME/durer/.venv/bin/activate" in script
    assert f"--nworkers {slurm['processes']}" in script and "--nthreads 1" in script
    assert cluster.scheduler_address in script
