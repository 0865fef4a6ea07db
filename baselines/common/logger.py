"""CSV logging of scalars (one row per call), mirrored to TensorBoard when ``torch.utils.tensorboard`` imports.

The CSV file is opened in append mode, so a resumed run keeps adding to the same file; when a later row has
keys the header lacks, the file is rewritten once with the wider header.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any


class CSVLogger:
    """``log(step, **scalars)`` appends a row ``step, key1, key2, ...`` to ``directory/filename``."""

    def __init__(self, directory: str | Path, filename: str = "progress.csv", tensorboard: bool = True):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.path = self.directory / filename
        self.fields: list[str] = []
        if self.path.exists() and self.path.stat().st_size > 0:
            with self.path.open(newline="") as f:
                self.fields = next(csv.reader(f), [])
        self._writer = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter
            except ImportError:  # tensorboard is optional
                SummaryWriter = None
            if SummaryWriter is not None:
                self._writer = SummaryWriter(log_dir=str(self.directory / "tensorboard"))

    def log(self, step: int, **scalars: Any) -> None:
        row = {"step": int(step), **{k: v.item() if hasattr(v, "item") else v for k, v in scalars.items()}}
        new_fields = [k for k in row if k not in self.fields]
        if new_fields:
            self._widen(self.fields + new_fields if self.fields else list(row))
        with self.path.open("a", newline="") as f:
            csv.DictWriter(f, fieldnames=self.fields).writerow(row)
        if self._writer is not None:
            for key, value in row.items():
                if key != "step" and isinstance(value, (int, float)):
                    self._writer.add_scalar(key, value, int(step))

    def _widen(self, fields: list[str]) -> None:
        rows = []
        if self.path.exists() and self.path.stat().st_size > 0:
            with self.path.open(newline="") as f:
                rows = list(csv.DictReader(f))
        self.fields = fields
        with self.path.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=fields)
            writer.writeheader()
            writer.writerows(rows)

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()

