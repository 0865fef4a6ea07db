"""Which machine trained which steps of a run: ``machines.csv`` in the run directory, one row per start or resume.

The results table states its hours "on the machine kind used"; a run resumed elsewhere (a lent 16-core machine,
then a 2-core one) has one row per stretch, each with the step it started from, so the table can say which
machine trained which steps (``experiments.table_sources.machine_summary``). The name carries the widest vector
instructions the processor has, because virtual machines hide the model behind one name: two "AMD EPYC" machines
here trained 3.5-4x apart (AVX-512 Zen 5 at ~3,500 env steps/s on UnitreeA1.simple GAIL, AVX2 at ~950). The x86
family and model numbers follow it: AVX-512 alone does not tell Zen 4 (family 25) from Zen 5 (family 26), whose matrix
products ran 2.4x apart here (BENCHMARKS.md).
"""

from __future__ import annotations

import csv
import functools
import os
import platform
import time
from pathlib import Path

MACHINES = "machines.csv"
FIELDS = ("step", "machine", "cpus", "torch_threads", "started")


@functools.cache
def _first_processor() -> dict[str, str]:
    """The first processor's fields of ``/proc/cpuinfo`` (``model name``, ``flags``, ...); {} where there is none.

    Read once a process: the fields used here do not change while it runs."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return {}
    fields: dict[str, str] = {}
    for line in lines:
        if not line.strip() and fields:  # the end of the first processor's block
            break
        key, sep, value = line.partition(":")
        if sep:
            fields.setdefault(key.strip(), value.strip())
    return fields


def cpu_model() -> str:
    """The processor's model name (``/proc/cpuinfo``), else what ``platform`` knows of it."""
    name = _first_processor().get("model name")
    return " ".join(name.split()) if name else platform.processor() or platform.machine() or "unknown CPU"


def vector_isa() -> str | None:
    """The widest x86 vector instruction set the processor reports (``AVX-512``, ``AVX2``, ``AVX``), else None."""
    flags = set(_first_processor().get("flags", "").split())
    return next((name for flag, name in (("avx512f", "AVX-512"), ("avx2", "AVX2"), ("avx", "AVX")) if flag in flags),
                None)


def cpu_generation() -> str | None:
    """The x86 ``family F model M`` of ``/proc/cpuinfo`` (a processor generation), else None."""
    fields = _first_processor()
    if "cpu family" not in fields or "model" not in fields:
        return None
    return f"family {fields['cpu family']} model {fields['model']}"


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity where the OS tells it, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def describe(cpus: int | None = None) -> str:
    """A short name of the machine kind, e.g. ``AMD EPYC, AVX-512, family 25 model 17 (2 CPUs)``."""
    details = "".join(f", {part}" for part in (vector_isa(), cpu_generation()) if part)
    return f"{cpu_model()}{details} ({cpus or usable_cpus()} CPUs)"


def read_machines(run_dir: str | Path) -> list[dict[str, str]]:
    """The rows of ``run_dir``'s ``machines.csv``, oldest first; [] for a run that has none (older runs)."""
    path = Path(run_dir) / MACHINES
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def record_machine(run_dir: str | Path, step: int, torch_threads: int) -> None:
    """Log that training of ``run_dir`` (re)starts at ``step`` on this machine.

    Rows from ``step`` on are dropped first: they began stretches whose epochs were never checkpointed (a resume
    goes back to the checkpoint; a warm start's copy of its source's file goes on from the step it loaded).
    """
    path = Path(run_dir) / MACHINES
    rows = [r for r in read_machines(run_dir) if int(r["step"]) < step]
    rows.append({"step": str(step), "machine": describe(), "cpus": str(usable_cpus()),
                 "torch_threads": str(torch_threads), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)

