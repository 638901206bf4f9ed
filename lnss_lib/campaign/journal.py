"""The evaluation journal ``evaluations.jsonl``: the run's persistent evaluation cache.

One JSON line per design evaluated, appended (and flushed) as each design finishes; the header line
holds the evaluation hash (:func:`~lnss_lib.campaign.settings.evaluation_hash`) and the format
version, so a design is never evaluated twice in a run, even across kills. One parser
(:func:`parse_journal`) serves the cache and :func:`read_cache_records`.
"""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["EvaluationCache", "read_cache_records", "parse_journal", "JOURNAL_FILE", "FORMAT_VERSION"]

JOURNAL_FILE = "evaluations.jsonl"
FORMAT_VERSION = 1


def parse_journal(data: bytes) -> tuple[dict, list[dict], int]:
    """(header, records in file order, length of the complete lines) of a journal's bytes.

    Only complete records count: a last line without its newline (cut short by a kill) is left out,
    and so is any line that is not a whole JSON record (torn by a full disk); the designs they held
    are evaluated again on resume.
    """
    end = data.rfind(b"\n") + 1
    lines = data[:end].decode(errors="replace").splitlines()
    header, records = {}, []
    for number, line in enumerate(lines):
        try:
            item = json.loads(line)
        except json.JSONDecodeError:
            continue
        if number == 0:
            header = item if isinstance(item, dict) else {}
        elif isinstance(item, dict):
            records.append(item)
    return header, records, end


class EvaluationCache:
    """The run's evaluations, keyed by scaled design (tuple of 6 ints), backed by an append-only JSON-lines file.

    The first line records the evaluation hash; each further line is one record
    ``{"key", "generation", "order", "metrics", "ok", "impact", "error", "reason", ...}`` (``error`` True:
    the evaluation raised, ``reason`` holds the message). A line cut short by a kill is dropped (and the
    file truncated to the last complete line) on opening; ``n_errors`` counts the error records.
    Opening a file written under another evaluation hash raises ValueError.
    """

    def __init__(self, path: Path, eval_hash: str):
        self.path = Path(path)
        self.eval_hash = eval_hash
        self.n_errors = 0
        self.created = False
        self.records: dict[tuple, dict] = {}
        if self.path.exists() and b"\n" in self.path.read_bytes():
            self._load()
        else:
            self.path.write_text(json.dumps({"evaluation_hash": eval_hash, "format": FORMAT_VERSION}) + "\n")
            self.created = True
        self._handle = self.path.open("a")

    def _load(self) -> None:
        data = self.path.read_bytes()
        header, records, end = parse_journal(data)
        if end < len(data):
            with self.path.open("r+b") as handle:
                handle.truncate(end)
        if header.get("evaluation_hash") != self.eval_hash:
            raise ValueError(f"{self.path} holds evaluations for evaluation hash {header.get('evaluation_hash')!r}, "
                             f"not {self.eval_hash!r}: the parameters that change an evaluation differ")
        self.records = {tuple(record["key"]): record for record in records}
        self.n_errors = sum(bool(r.get("error")) for r in self.records.values())

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
            self._handle.write(json.dumps(record) + "\n")
            self._handle.flush()
        except OSError as error:           # a full disk names the journal, not only the errno
            raise OSError(error.errno, error.strerror or str(error), str(self.path)) from error

    def first_error(self) -> dict | None:
        """The first record (in evaluation order) whose evaluation raised, or None."""
        return next((r for r in self.records.values() if r.get("error")), None)

    def close(self) -> None:
        self._handle.close()


def read_cache_records(run_dir) -> list[dict]:
    """Every record of a run's evaluation cache, in file order (complete lines only)."""
    path = Path(run_dir) / JOURNAL_FILE
    if not path.is_file():
        return []
    return parse_journal(path.read_bytes())[1]
