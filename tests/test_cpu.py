"""The CPU a run computes on: recorded in run.json, and torch's kernels pinned to AVX2 (gdabench.cpu)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from gdabench import cpu

pinnable = pytest.mark.skipif(not cpu.pinnable(), reason="not an x86-64 CPU with AVX2")


def python(code: str, **env: str) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k not in cpu.PINS and k != cpu.ISA_VARIABLE}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env={**environ, **env},
                          timeout=300)  # fmt: skip


def test_run_json_records_the_cpu_model_its_instruction_sets_and_the_kernels(tmp_path):
    import gdabench

    run = gdabench.compare("random", "simple", budget=25, out=tmp_path / "run", progress=False)
    recorded = run.meta["platform"]["cpu"]
    assert recorded == cpu.info() and recorded["model"] and "kernels" in recorded


@pinnable
def test_importing_gdabench_pins_torchs_kernels_and_native_lifts_it():
    code = "import gdabench, torch; print(torch.backends.cpu.get_cpu_capability(), gdabench.cpu.info()['kernels'])"
    assert python(code).stdout.split() == ["AVX2", "avx2", "(pinned)"]
    assert python(code, GDABENCH_ISA="native").stdout.split()[1:] == ["native"]


@pinnable
def test_gda_warns_when_torch_was_imported_before_gdabench():
    code = ("import warnings, torch, gdabench\nwarnings.simplefilter('error')\n"
            "gdabench.make_designer('gda', shape=(5, 5), population=25, budget=100)")  # fmt: skip
    assert "this run's rows may differ on another CPU" in python(code).stderr
    assert python(code.replace("torch, gdabench", "gdabench, torch")).returncode == 0
