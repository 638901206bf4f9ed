"""The evaluation journal ``evaluations.jsonl``: the run's persistent evaluation cache.

One JSON line per design evaluated, appended (and flushed) as each design finishes; the header line
holds the evaluation hash (:func:`~lnss_lib.campaign.settings.evaluation_hash`) and the format
version, so a design is never evaluated twice in a run, even across kills. Each record line ends with
the CRC-32 of the rest (format 2). One parser (:func:`parse_journal`) serves the cache and
:func:`read_cache_records`: each design counts once (its first record; an error record gives way to a
later record of the design), and a line that is not a whole record or fails its CRC (torn, damaged,
from any generation) is skipped, so its design is evaluated again.

Each record names the processor model its kernels were compiled for (``kernel_cpu``, :func:`lnss_lib.kernel_cpu`;
records written before it did are the run's model, recorded in ``run.json``). The gravity kernels' bits follow the
model, and the adaptive step control carries that round-off up to 2e-7 relative after 10 days; the evaluation
hash leaves the model out (a run resumed on another machine keeps its settings), so the journal answers a design
from its record only on the record's model: on another a record is no hit, and the design is evaluated again (its
later record then stands for it).
"""

from __future__ import annotations

import json
import warnings
import zlib
from collections import Counter
from pathlib import Path

from ..atomicio import write_bytes_atomic

__all__ = [
    "EvaluationCache",
    "read_cache_records",
    "parse_journal",
    "encode_record",
    "JOURNAL_FILE",
    "FORMAT_VERSION",
]

JOURNAL_FILE = "evaluations.jsonl"
FORMAT_VERSION = 2  # 1: records without the CRC
CRC_FIELD = "crc32"
CPU_FIELD = "kernel_cpu"  # the processor model of a record's kernels (campaign.tasks.worker_fields)


def _crc(text: str) -> str:
    return f"{zlib.crc32(text.encode()):08x}"


def encode_record(record: dict) -> str:
    """One journal line (without its newline): the record's JSON with the CRC-32 of that JSON as last field."""
    body = json.dumps(record)
    return f'{body[:-1]}, "{CRC_FIELD}": "{_crc(body)}"}}'


def _decode_record(item, crc_required: bool, is_record) -> dict | None:
    """The record of a parsed line when its CRC (if any; required from format 2) matches and ``is_record``
    accepts it, else None."""
    if not isinstance(item, dict):
        return None
    crc = item.pop(CRC_FIELD, None)
    if crc is None and crc_required or crc is not None and crc != _crc(json.dumps(item)):
        return None
    return item if is_record(item) else None


def _is_record(item) -> bool:
    """A whole evaluation record: a dict with a 6-integer design key and an integer generation."""
    key = item.get("key") if isinstance(item, dict) else None
    return (
        isinstance(key, list)
        and len(key) == 6
        and all(type(v) is int for v in key)
        and type(item.get("generation")) is int
        and isinstance(item.get("metrics", {}), dict)
    )


_REPORTED: set[tuple[str, tuple]] = set()  # (journal, damaged lines) already named in this process


def parse_journal(data: bytes, is_record=_is_record, source=None) -> tuple[dict, list[dict], int]:
    """(header, one record per design in order of first appearance, length of the complete lines) of a
    journal's bytes; ``is_record`` tells a whole record (default: an evaluation record; the front validation's
    journal has its own, :mod:`lnss_lib.campaign.validation`).

    Only complete records count: a last line without its newline (cut short by a kill) is left out,
    and so is any line that is not a whole record or whose CRC does not match (torn by a full disk,
    damaged later; a journal of format 1 has no CRC); the designs they held are evaluated again on resume. A design recorded twice (two writers) counts once: its
    first record, unless that one is an error record or of another processor model (``kernel_cpu``) and a later
    one exists (a retry after the cause of the error was removed; an evaluation again on another model). A line that does not parse at all (not JSON, nested too deep, a number too long to
    read) is skipped like any other; with ``source`` (the file) the skipped lines are named in a RuntimeWarning
    (once per process).
    """
    end = data.rfind(b"\n") + 1
    lines = data[:end].decode(errors="replace").splitlines()
    header, by_key, damaged = {}, {}, []
    for number, line in enumerate(lines):
        try:
            item = json.loads(line)
            record = (
                None
                if number == 0
                else _decode_record(item, header.get("format", FORMAT_VERSION) >= 2, is_record)
            )
        except (
            ValueError,
            RecursionError,
        ):  # JSONDecodeError, a 5000-digit integer, nesting past the limit
            damaged.append(number + 1)
            continue
        if number == 0:
            header = (
                item
                if (
                    isinstance(item, dict)
                    and "evaluation_hash" in item
                    and type(item.get("format", FORMAT_VERSION)) is int
                )
                else {}
            )
        elif record is None:
            damaged.append(number + 1)
        else:
            key = tuple(record["key"])
            if (
                key not in by_key
                or by_key[key].get("error")
                or by_key[key].get(CPU_FIELD) != record.get(CPU_FIELD)
            ):
                by_key[key] = record
    if damaged and source is not None and (str(source), tuple(damaged)) not in _REPORTED:
        _REPORTED.add((str(source), tuple(damaged)))
        shown = ", ".join(map(str, damaged[:5])) + (
            f" and {len(damaged) - 5} more" if len(damaged) > 5 else ""
        )
        warnings.warn(
            f"{source}: line(s) {shown} damaged (not a whole record or a wrong CRC): skipped, their "
            f"designs are evaluated again",
            RuntimeWarning,
            stacklevel=2,
        )
    return header, list(by_key.values()), end


class EvaluationCache:
    """The run's evaluations, keyed by scaled design (tuple of 6 ints), backed by an append-only JSON-lines file.

    The first line records the evaluation hash; each further line is one record
    ``{"key", "generation", "order", "metrics", "ok", "impact", "error", "reason", ...}`` (``error`` True:
    the evaluation raised, ``reason`` holds the message). A line cut short by a kill is dropped (and the
    file truncated to the last complete line) on opening; so are error records of earlier sessions, so
    that a run stopped by an evaluation error evaluates those designs again once resumed. ``n_errors``
    counts the error records of this session. A damaged header line is written again (the file is the
    run folder's own); a header naming another evaluation hash raises ValueError. ``is_record``: as in
    :func:`parse_journal` (keys are then tuples of whatever the records' keys hold).

    ``kernel_cpu`` (None: any model): the processor model this session's kernels are compiled for; a record of
    another model (its ``kernel_cpu``, else ``run_cpu``, the run's recorded model) is no hit, its design is evaluated
    again (see the module docstring), and a RuntimeWarning says how many and why; ``n_other_cpu`` counts them.
    """

    def __init__(
        self,
        path: Path,
        eval_hash: str,
        is_record=_is_record,
        *,
        kernel_cpu: str | None = None,
        run_cpu: str | None = None,
    ):
        self.path = Path(path)
        self.eval_hash = eval_hash
        self.is_record = is_record
        self.kernel_cpu, self.run_cpu = kernel_cpu, run_cpu
        self.n_other_cpu = 0
        self.n_errors = 0
        self.created = False
        self.records: dict[tuple, dict] = {}
        if self.path.exists() and b"\n" in self.path.read_bytes():
            self._load()
        else:
            write_bytes_atomic(self.path, self._header())
            self.created = True
        self._handle = self.path.open("a")

    def _header(self) -> bytes:
        return (
            json.dumps({"evaluation_hash": self.eval_hash, "format": FORMAT_VERSION}) + "\n"
        ).encode()

    def _load(self) -> None:
        data = self.path.read_bytes()
        header, records, end = parse_journal(data, self.is_record, source=self.path)
        if "evaluation_hash" not in header:  # header line damaged: keep the records after it
            write_bytes_atomic(self.path, self._header() + data[data.find(b"\n") + 1 : end])
        elif end < len(data):
            with self.path.open("r+b") as handle:
                handle.truncate(end)
        if header.get("evaluation_hash", self.eval_hash) != self.eval_hash:
            raise ValueError(
                f"{self.path} holds evaluations for evaluation hash {header.get('evaluation_hash')!r}, "
                f"not {self.eval_hash!r}: the parameters that change an evaluation differ"
            )
        self.records = {
            tuple(record["key"]): record
            for record in records
            if not record.get("error") and self._same_cpu(record)
        }
        other = Counter(
            record.get(CPU_FIELD, self.run_cpu)
            for record in records
            if not record.get("error") and not self._same_cpu(record)
        )
        self.n_other_cpu = sum(other.values())
        if other:
            models = ", ".join(
                f"{n} with kernels compiled for {model}" for model, n in other.items()
            )
            warnings.warn(
                f"{self.path}: {self.n_other_cpu} design(s) evaluated on another processor model ({models}); "
                f"here the kernels are compiled for {self.kernel_cpu}: they are evaluated again, since "
                f"another model's round-off is not this machine's result",
                RuntimeWarning,
                stacklevel=3,
            )

    def _same_cpu(self, record: dict) -> bool:
        """Whether ``record`` was evaluated with kernels of this session's model (always, without a model)."""
        return self.kernel_cpu is None or record.get(CPU_FIELD, self.run_cpu) in (
            self.kernel_cpu,
            None,
        )

    def __contains__(self, key: tuple) -> bool:
        return key in self.records

    def __len__(self) -> int:
        return len(self.records)

    def add(self, key: tuple, record: dict) -> None:
        """Store ``record`` under ``key`` and append it to the file (flushed)."""
        record = {"key": list(key), **record}
        self.records[key] = record
        self.n_errors += bool(record.get("error"))
        try:
            self._handle.write(encode_record(record) + "\n")
            self._handle.flush()
        except OSError as error:  # a full disk names the journal, not only the errno
            raise OSError(error.errno, error.strerror or str(error), str(self.path)) from error

    def first_error(self) -> dict | None:
        """The first record (in evaluation order) whose evaluation raised, or None."""
        return next((r for r in self.records.values() if r.get("error")), None)

    def close(self) -> None:
        self._handle.close()


def read_cache_records(run_dir) -> list[dict]:
    """One record per design of a run's evaluation cache (:func:`parse_journal`), in order of first appearance."""
    path = Path(run_dir) / JOURNAL_FILE
    if not path.is_file():
        return []
    return parse_journal(path.read_bytes(), source=path)[1]
