"""Batch assessment: run_batch (cases -> table and records) and assess_many (Python API)."""
import os
import time
from dataclasses import dataclass, field

from ..core.errors import InputError
from ..core.thresholds import check_positive
from . import runner
from .cases import expand_cases, make_settings, settings_hash
from .progress import BatchProgress
from .store import BatchStore
from .table import TableWriter, columns, write_table

#: Keyword options of assess_many / run_batch that are assessment settings.
OPTION_KEYS = ("lref", "h_f", "k_f", "backend", "faces", "order", "rtol", "max_depth", "object")


@dataclass
class BatchResult:
    """Outcome of a batch: rows in case order and what this run did.

    evaluated: cases assessed in this run; skipped: cases found done in --out (resume);
    failed: cases of this run that ended in an error; table_path: signatures.csv or None.
    """

    rows: list
    evaluated: int
    skipped: int
    failed: int
    elapsed_s: float
    settings: dict
    settings_hash: str
    out: str = None
    table_path: str = None
    failures: list = field(default_factory=list)


def _param_names(cases):
    names = []
    for c in cases:
        for n in c.params:
            if n not in names:
                names.append(n)
    return names


def _runner_for(workers, scheduler, start_method):
    if scheduler is not None:
        return lambda cases, s, h: runner.run_dask(cases, s, h, scheduler), "dask"
    if workers == 0:
        return runner.run_serial, "serial"
    return (lambda cases, s, h: runner.run_local(cases, s, h, workers, start_method)), "local"


def run_batch(cases, settings, out=None, workers=None, scheduler=None, resume=True, progress=False,
              start_method="spawn"):
    """Assess cases (from cases.expand_cases) with settings (cases.make_settings).

    out: folder for signatures.csv, cases/<case_id>.json and batch.json (None: nothing
    written, nothing resumed). workers: local processes (None: the available CPUs; 0: in this
    process). scheduler: Dask scheduler address or Client (overrides workers). resume: skip
    cases done in out with the same input hash and settings hash. progress: bar on stderr.
    """
    if workers is not None and int(workers) < 0:
        raise InputError("workers must be 0 (this process) or more, got %r" % (workers,))
    t0 = time.monotonic()
    shash = settings_hash(settings)
    store = BatchStore(out) if out else None
    previous = store.previous() if store and resume else {}
    rows, todo = {}, []
    for case in cases:
        prev = previous.get(case.case_id)
        if BatchStore.is_done(case, shash, prev):
            rows[case.case_id] = dict(prev["row"], input=case.path)
        else:
            todo.append(case)
    skipped = len(rows)
    cols = columns(_param_names(cases))
    client = None
    if isinstance(scheduler, str) and todo:  # connect before touching the output folder
        client = runner.connect(scheduler)
    run, kind = _runner_for(workers, client or scheduler, start_method)
    bar = BatchProgress(len(todo), skipped, enabled=progress)
    writer = None
    failures = []
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    if store:
        store.prepare()
        writer = TableWriter(store.table_path, cols)
        for case in cases:
            if case.case_id in rows:
                writer.write(rows[case.case_id])
    records = run(todo, settings, shash) if todo else iter(())
    try:
        for record in records:
            row = record["row"]
            rows[row["case_id"]] = row
            if record["status"] != "ok":
                failures.append((row["case_id"], row["error"]))
            if store:
                store.write_record(record)
                writer.write(row)
            bar.update(record)
    finally:
        if hasattr(records, "close"):
            records.close()  # stops the workers / withdraws the tasks when interrupted
        bar.close()
        if client is not None:
            client.close()
        ordered = [rows[c.case_id] for c in cases if c.case_id in rows]
        if store:
            writer.close()
            write_table(store.table_path, ordered, cols)  # final table in case order
            store.write_manifest({
                "settings": settings, "settings_hash": shash, "runner": kind,
                "workers": None if kind != "local" else (workers or runner.default_workers()),
                "scheduler": scheduler if isinstance(scheduler, str) else None,
                "cases": len(cases), "evaluated": len(ordered) - skipped, "skipped": skipped,
                "failed": len(failures), "started": started,
                "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "table": os.path.basename(store.table_path)})
    return BatchResult(ordered, len(ordered) - skipped, skipped, len(failures), time.monotonic() - t0,
                       settings, shash, store.out if store else None, store.table_path if store else None,
                       failures)


def backend_keywords():
    """Further keyword options that assess() passes on (to the BRep backend), beyond OPTION_KEYS."""
    import inspect
    try:
        from ..brep.backend import assess_brep
    except ImportError:
        return []
    params = list(inspect.signature(assess_brep).parameters.values())[1:]  # not the source
    return sorted({p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
                  - set(OPTION_KEYS) - {"with_fields", "progress"})


def split_options(options):
    """Batch settings (cases.make_settings) from keyword options.

    OPTION_KEYS are the common settings; any other key must be a keyword of a backend
    (backend_keywords(), e.g. display_deflection) and is passed on to assess().
    """
    extra = {k: v for k, v in options.items() if k not in OPTION_KEYS}
    if extra:
        known = backend_keywords()
        unknown = sorted(set(extra) - set(known))
        if unknown:
            raise InputError("unknown option(s) %s; known: %s" % (", ".join(unknown), ", ".join(OPTION_KEYS + tuple(known))))
    common = {k: v for k, v in options.items() if k in OPTION_KEYS}
    for name in ("lref", "h_f", "k_f", "rtol"):
        if common.get(name) is not None:
            check_positive(name, common[name])
    for name in ("order", "max_depth"):
        if common.get(name) is not None and int(common[name]) < 1:
            raise InputError("%s must be a positive integer, got %r" % (name, common[name]))
    if common.get("backend") not in (None, "mesh", "brep"):
        raise InputError("backend must be 'mesh', 'brep' or None, got %r" % (common["backend"],))
    return make_settings(extra=extra, **common)


def assess_many(sources, workers=None, scheduler=None, out=None, variants=None, progress=False, resume=True,
                as_frame=False, start_method="spawn", **options):
    """Signatures of many hulls: one row per case (see batch.table for the columns).

    sources: hull files, folders, glob patterns and FreeCAD documents (a path or a list);
    variants: CSV variant table for the documents (one case per row); workers, scheduler,
    out, resume, progress: as run_batch; options: lref, h_f, k_f, backend, faces, order,
    rtol, max_depth, object (hull object of the documents) and backend keywords (e.g.
    display_deflection). Returns the rows as a list of
    dicts (values typed, None where not established), or a pandas DataFrame when
    as_frame=True (pandas is then required).
    """
    settings = split_options(options)
    pandas = None
    if as_frame:
        try:
            import pandas
        except ImportError:
            raise InputError("as_frame=True needs pandas, which is not installed; use the list of rows") from None
    cases = expand_cases(sources, variants=variants, object_name=settings["object"])
    result = run_batch(cases, settings, out=out, workers=workers, scheduler=scheduler, resume=resume,
                       progress=progress, start_method=start_method)
    if pandas is None:
        return result.rows
    return pandas.DataFrame(result.rows, columns=columns(_param_names(cases)))
