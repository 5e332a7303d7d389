"""The manifest of a batch: which pairs to splice (YAML or CSV), read into :class:`PairJob` s.

YAML: a list of pairs, or ``{options: {...}, pairs: [...]}``; each pair has ``body``,
``hands``, ``output`` and optionally ``constraints``, ``name`` and ``options`` (fields of
:class:`~splicer.options.SpliceOptions`).  CSV: a header with ``body,hands,output`` and
optionally ``constraints``, ``name``, ``options`` (``key=value; key=value``).  Relative paths
are relative to the manifest's folder.  Every complaint names the file and line.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path

from .errors import SplicerError

__all__ = ["PairJob", "ManifestError", "read_manifest"]

_PAIR_KEYS = {"name", "body", "hands", "constraints", "output", "options"}


class ManifestError(SplicerError):
    """The manifest is malformed (the message names file and line)."""


@dataclass(frozen=True)
class PairJob:
    """One pair to splice.

    Attributes
    ----------
    name : str
        Unique in the batch; names the report and plot.
    body, hands : str
        Input BVH paths (absolute).
    output : str
        Output BVH path (absolute).
    constraints : str or None
        Constraints file (absolute).
    options : dict
        :class:`~splicer.options.SpliceOptions` fields for this pair.
    line : int
        Line of the entry in the manifest (0 for pairs found by pairing).
    """

    name: str
    body: str
    hands: str
    output: str
    constraints: str | None = None
    options: dict = field(default_factory=dict)
    line: int = 0


# ---------------------------------------------------------------- manifest

def _check_options(opts: dict, where: str) -> dict:
    from .options import resolve_options

    try:
        resolve_options(None, dict(opts))
    except (TypeError, SplicerError) as e:
        raise ManifestError(f"{where}: {e}") from None
    return dict(opts)


def _make_job(entry: dict, base: Path, defaults: dict, where: str, line: int) -> PairJob:
    unknown = sorted(set(entry) - _PAIR_KEYS)
    if unknown:
        raise ManifestError(f"{where}: unknown key(s) {', '.join(unknown)}; expected {', '.join(sorted(_PAIR_KEYS))}")
    for k in ("body", "hands", "output"):
        if not entry.get(k):
            raise ManifestError(f"{where}: '{k}' is missing")

    def path(v):
        p = Path(str(v)).expanduser()
        return str(p if p.is_absolute() else (base / p).resolve())

    opts = entry.get("options") or {}
    if not isinstance(opts, dict):
        raise ManifestError(f"{where}: 'options' must be a mapping of option names to values")
    out = path(entry["output"])
    name = str(entry.get("name") or Path(out).stem)
    cons = entry.get("constraints")
    return PairJob(name, path(entry["body"]), path(entry["hands"]), out, path(cons) if cons else None,
                   _check_options({**defaults, **opts}, where), line)


def _parse_cell_options(text: str, where: str) -> dict:
    import yaml

    opts = {}
    for part in filter(None, (p.strip() for p in (text or "").split(";"))):
        if "=" not in part:
            raise ManifestError(f"{where}: options: expected key=value, found {part!r}")
        k, v = (s.strip() for s in part.split("=", 1))
        opts[k] = yaml.safe_load(v) if v else None
    return opts


def read_manifest(path) -> list[PairJob]:
    """Read a YAML or CSV manifest.

    YAML: a list of pairs, or ``{options: {...}, pairs: [...]}`` with ``options`` applied to
    every pair.  CSV: a header with ``body,hands,output`` and optionally ``constraints``,
    ``name``, ``options`` (``key=value; key=value``).

    Raises
    ------
    ManifestError
        Unreadable or malformed manifest, an unknown option, duplicate names or outputs;
        the message names the file and line.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ManifestError(f"{p}: manifest not found") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ManifestError(f"{p}: cannot read the manifest ({e})") from None
    base = p.resolve().parent
    jobs = []
    if p.suffix.lower() == ".csv":
        reader = csv.DictReader(io.StringIO(text))
        cols = set(reader.fieldnames or [])
        missing = {"body", "hands", "output"} - cols
        if missing:
            raise ManifestError(f"{p}, line 1: the header lacks {', '.join(sorted(missing))} "
                                f"(columns: body, hands, output, constraints, name, options)")
        for row in reader:
            line = reader.line_num
            where = f"{p}, line {line}"
            entry = {k: (v.strip() if isinstance(v, str) else v) for k, v in row.items() if k and v not in (None, "")}
            if not entry:
                continue
            if "options" in entry:
                entry["options"] = _parse_cell_options(entry["options"], where)
            jobs.append(_make_job(entry, base, {}, where, line))
    else:
        import yaml

        try:
            root = yaml.compose(text, Loader=yaml.SafeLoader)
        except yaml.YAMLError as e:
            mark = getattr(e, "problem_mark", None)
            raise ManifestError(f"{p}{f', line {mark.line + 1}' if mark else ''}: not valid YAML "
                                f"({getattr(e, 'problem', None) or e})") from None
        defaults = {}
        if isinstance(root, yaml.MappingNode):
            top = {k.value: v for k, v in root.value}
            extra = sorted(set(top) - {"pairs", "options"})
            if extra or "pairs" not in top:
                raise ManifestError(f"{p}, line {root.start_mark.line + 1}: expected 'pairs:' (and optionally "
                                    f"'options:') at the top level" + (f", found {', '.join(extra)}" if extra else ""))
            if "options" in top:
                defaults = yaml.safe_load(yaml.serialize(top["options"])) or {}
                if not isinstance(defaults, dict):
                    raise ManifestError(f"{p}, line {top['options'].start_mark.line + 1}: 'options' must be a mapping")
            root = top["pairs"]
        if not isinstance(root, yaml.SequenceNode):
            line = root.start_mark.line + 1 if root is not None else 1
            raise ManifestError(f"{p}, line {line}: expected a list of pairs (body, hands, output, ...)")
        for node in root.value:
            line = node.start_mark.line + 1
            entry = yaml.safe_load(yaml.serialize(node))
            if not isinstance(entry, dict):
                raise ManifestError(f"{p}, line {line}: a pair is a mapping with body, hands, output")
            jobs.append(_make_job(entry, base, defaults, f"{p}, line {line}", line))
    _check_unique(jobs, str(p))
    return jobs


def _check_unique(jobs: list[PairJob], source: str) -> None:
    for attr in ("name", "output"):
        seen = {}
        for j in jobs:
            v = getattr(j, attr)
            if v in seen:
                raise ManifestError(f"{source}, line {j.line}: {attr} {v!r} is used twice (first at line {seen[v]})")
            seen[v] = j.line
    inputs = {j.body for j in jobs} | {j.hands for j in jobs} | {j.constraints for j in jobs}
    for j in jobs:
        if j.output in inputs:
            raise ManifestError(f"{source}, line {j.line}: output {j.output} is an input of the batch")
