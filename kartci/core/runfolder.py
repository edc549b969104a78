"""`RunFolder`: the one owner of a run folder's file names (OUT/<label>, a repeat's
OUT/<label>/repeat_<k>, or a run's private staging folder) and of its run state (marked
failed, complete), so that the runner, the importers, the reports and the CLI write and read
one layout instead of each spelling it. It is what travels: a function that works on a run
folder takes a `RunFolder`, made once where the folder's path is decided.

A run folder holds `run.mcap` (the log), `metrics.json` (deterministic), `run.json` (wall-clock
facts), and while or after a run fails `error.json` (with `traceback.txt` for a crash); a run
in progress writes into a `.new-*` staging folder inside it.
"""

from __future__ import annotations

import os
import tempfile
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from kartci.atomic import write_json_atomic, write_text_atomic
from kartci.boundedio import RefusedFileError, is_number, read_json
from kartci.errors import BaselineError, KartciError, LogError, SpecError, one_line

UNFINISHED = "the run did not finish (interrupted, or its process died)"  # error.json's reason


@dataclass(frozen=True)
class RunFolder:
    """A run folder's path and the names of what a run writes there."""

    path: Path

    LOG_NAME: ClassVar[str] = "run.mcap"
    METRICS_NAME: ClassVar[str] = "metrics.json"
    RUN_RECORD_NAME: ClassVar[str] = "run.json"
    ERROR_NAME: ClassVar[str] = "error.json"  # the last run failed (older outputs are kept)
    TRACEBACK_NAME: ClassVar[str] = "traceback.txt"  # beside error.json after a crash
    STAGE_PREFIX: ClassVar[str] = ".new-"  # a run in progress; moved into place when complete
    ATTACH_SUFFIX: ClassVar[str] = ".attach.json"  # <agent>.attach.json: into run.json's attach
    OUTPUTS: ClassVar[tuple[str, ...]] = (LOG_NAME, METRICS_NAME, RUN_RECORD_NAME)

    @property
    def name(self) -> str:
        """The folder's label (the scenario, sweep point or repeat it holds)."""
        return self.path.name

    @property
    def log(self) -> Path:
        """The run's MCAP log."""
        return self.path / self.LOG_NAME

    @property
    def metrics(self) -> Path:
        """The scored metrics (byte-identical for identical logs)."""
        return self.path / self.METRICS_NAME

    @property
    def run_record(self) -> Path:
        """The run's wall-clock facts (time, platform, warnings)."""
        return self.path / self.RUN_RECORD_NAME

    @property
    def error(self) -> Path:
        """The failure mark: present while a run is under way and after one failed."""
        return self.path / self.ERROR_NAME

    @property
    def traceback(self) -> Path:
        """A crashed run's full traceback, for debugging only."""
        return self.path / self.TRACEBACK_NAME

    def attach(self, agent: str) -> Path:
        """Where an external agent records how to attach ROS 2 tools to its run (staged)."""
        return self.path / f"{agent}{self.ATTACH_SUFFIX}"

    def read_attach(self) -> dict[str, Any]:
        """Every agent's attach record, by agent ({} when none wrote one)."""
        out = {}
        for path in sorted(self.path.glob(f"*{self.ATTACH_SUFFIX}")):
            try:
                out[path.name[:-len(self.ATTACH_SUFFIX)]] = read_json(path)
            except (OSError, ValueError) as err:
                raise LogError(f"{path}: unreadable attach record ({err})") from None
        return out

    def stages(self) -> list[Path]:
        """Staging folders left here by runs that were killed half-way."""
        return sorted(self.path.glob(f"{self.STAGE_PREFIX}*"))

    def new_stage(self) -> RunFolder:
        """A fresh private staging folder inside this one, for a run in progress."""
        return RunFolder(Path(tempfile.mkdtemp(prefix=self.STAGE_PREFIX, dir=self.path)))

    def adopt(self, stage: RunFolder) -> None:
        """Move a staged run's log, metrics and run record into this folder."""
        for name in self.OUTPUTS:
            os.replace(stage.path / name, self.path / name)

    def missing(self) -> list[str]:
        """The names of the log and metrics when absent: a folder lacking one is incomplete."""
        return [n for n in (self.LOG_NAME, self.METRICS_NAME) if not (self.path / n).is_file()]

    def failure(self) -> str | None:
        """The reason in the failure mark ("" when unreadable), None when there is none."""
        if not self.error.exists() and not self.error.is_symlink():
            return None
        try:
            return str(read_json(self.error).get("error", ""))
        except (OSError, ValueError, AttributeError):
            return ""

    def unfinished(self) -> bool:
        """Whether the command that started this folder's run stopped before it completed."""
        return self.failure() == UNFINISHED

    def mark_failed(self, scenario: str, error: str, err: BaseException | None = None) -> None:
        """Mark the folder as failed: its older outputs stay for debugging, but nothing
        (report, compare, baseline update) takes them for this run's. A crash (not a
        KartciError) also leaves its full traceback in traceback.txt; the message itself stays
        one line."""
        write_json_atomic(self.error, {"scenario": scenario, "error": one_line(error)})
        if err is not None and not isinstance(err, KartciError):
            write_text_atomic(self.traceback, "".join(traceback.format_exception(err)))
        else:
            self.traceback.unlink(missing_ok=True)

    def failed_reason(self) -> str | None:
        """Why the last run failed, as a result's error says it; None when not marked failed."""
        reason = self.failure()
        return None if reason is None else f"the last run failed: {one_line(reason)}".rstrip(": ")

    def check_complete(self) -> None:
        """Raise SpecError unless the outputs are one complete, current run: what `baseline
        update` may promote."""
        if not self.path.is_dir():
            raise SpecError(f"{self.path}: no such scenario folder")
        reason = self.failed_reason()
        if reason is not None:
            why = reason.removeprefix("the last run failed").lstrip(": ")
            raise SpecError(f"{self.path}: the last run of this scenario failed"
                            f"{f' ({why})' if why else ''}; its metrics are stale and will not "
                            "become a baseline")
        missing = self.missing()
        if missing:
            raise SpecError(f"{self.path}: incomplete (no {' or '.join(missing)}); run it again")

    def read_metrics(self) -> dict[str, dict[str, Any]]:
        """The metrics, checked: {NAME: {"value": number|null, ...}}; a BaselineError naming
        the file when it is missing or malformed."""
        path = self.metrics
        try:
            data = read_json(path)
            metrics = data.get("metrics") if isinstance(data, dict) else None
            if not isinstance(metrics, dict):
                raise ValueError('expected {"metrics": {NAME: {"value": ...}}}')
            for name, entry in metrics.items():
                if not isinstance(entry, dict) or not (entry.get("value") is None
                                                       or is_number(entry["value"])):
                    raise ValueError(f"{name}: expected {{\"value\": number or null, ...}}")
        except FileNotFoundError:
            raise BaselineError(f"{path}: not found; run `kartci run` first") from None
        except RefusedFileError as err:
            raise BaselineError(f"{path}: {err}") from None
        except (OSError, ValueError, UnicodeDecodeError) as err:
            raise BaselineError(f"{path}: malformed metrics file ({err})") from None
        return dict(metrics)

    def read_run_record(self) -> dict[str, Any]:
        """The run record ({} when there is none); a LogError naming it when unreadable."""
        path = self.run_record
        if not path.exists():
            return {}
        try:
            run = read_json(path)
        except (OSError, ValueError) as err:
            raise LogError(f"{path}: unreadable run record ({err})") from None
        if not isinstance(run, dict):
            raise LogError(f"{path}: expected a JSON object")
        return run
