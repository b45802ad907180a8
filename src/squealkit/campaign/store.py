"""The campaign's events and applications in an embedded analytical database (DuckDB).

Why DuckDB and not Parquet files: results arrive one application at a time from the workers
and are written by the one process that runs the campaign. A DuckDB file takes each
application as one ACID transaction, so a killed run leaves every finished application in
place and a re-run skips them (resume); a re-analysed application replaces its rows
atomically. Parquet files are immutable: the same would need one small file per application
(2,000 for a J2521 matrix) or batches that lose their progress when killed, and a compaction
step. The file is queried with plain SQL from DuckDB (Python, CLI, or any tool with a DuckDB
driver), and ``COPY applications TO 'apps.parquet'`` exports it when Parquet is wanted.

Tables: ``applications`` (one row per brake application: its conditions and results; ``status``
is ``'ok'`` or ``'failed'``, and ``error`` the one-line reason of a failed application, whose
results are empty; ``runout_unavailable`` says why an analysed application has no run-out link,
e.g. no disc speed),
``events`` (one row per squeal event, VDA 303 tonal component), and the view ``squeal``
(events with their application's conditions), e.g.::

    SELECT * FROM squeal WHERE peak_dba > 75 AND frequency_hz BETWEEN 6000 AND 8000 AND temperature_c > 150
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .._optional import require
from .._validation import InputError

__all__ = ["APPLICATION_COLUMNS", "EVENT_COLUMNS", "CampaignStore"]

APPLICATION_COLUMNS = {
    "application": "VARCHAR PRIMARY KEY", "file": "VARCHAR", "section": "VARCHAR", "mode": "VARCHAR",
    "pressure_bar": "DOUBLE", "temperature_c": "DOUBLE", "speed_kmh": "DOUBLE", "duration_s": "DOUBLE",
    "synthetic": "BOOLEAN", "squeal": "BOOLEAN", "peak_dba": "DOUBLE", "squeal_frequency_hz": "DOUBLE",
    "n_events": "INTEGER", "growth_slope_correlation": "DOUBLE", "rising_fraction": "DOUBLE",
    "runout_phase_deg": "DOUBLE", "mean_rpm": "DOUBLE", "criteria": "VARCHAR", "file_size": "BIGINT",
    "file_mtime_ns": "BIGINT", "error": "VARCHAR", "status": "VARCHAR", "runout_unavailable": "VARCHAR",
    "mu": "DOUBLE",
}
EVENT_COLUMNS = {
    "application": "VARCHAR", "event": "INTEGER", "start_s": "DOUBLE", "end_s": "DOUBLE", "duration_s": "DOUBLE",
    "frequency_hz": "DOUBLE", "peak_dba": "DOUBLE", "band_center_hz": "DOUBLE", "band_lo_hz": "DOUBLE",
    "band_hi_hz": "DOUBLE", "runout_phase_deg": "DOUBLE",
}


#: DuckDB's file header: 8 bytes of checksum, then the magic bytes.
_DUCKDB_MAGIC = (8, b"DUCK")
_SQLITE_MAGIC = b"SQLite format 3\0"


def _check_file(path: Path) -> None:
    """An existing store path is a non-empty DuckDB file (by its header), else one line saying what it is."""
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a campaign store (a DuckDB file); give another --out.")
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as e:
        raise InputError(f"{path}: the campaign store cannot be read: {e.strerror or e}.") from e
    if not head:
        raise InputError(f"{path}: the campaign store is empty (0 bytes), not a DuckDB file; remove it or give "
                         "another --out.")
    if head.startswith(_SQLITE_MAGIC):
        raise InputError(f"{path}: is a SQLite database, not a DuckDB campaign store; give another --out.")
    at, magic = _DUCKDB_MAGIC
    if head[at:at + len(magic)] != magic:
        raise InputError(f"{path}: is not a DuckDB file (no DuckDB header), so not a campaign store; "
                         "give another --out.")


def _store_error(path: Path, e: Exception) -> InputError:
    """One line for a DuckDB error on opening or reading a store: in use, no permission, or damaged."""
    text = str(e).splitlines()[0] if str(e) else type(e).__name__
    if "could not set lock" in text.lower() or "conflicting lock" in text.lower():
        return InputError(f"{path}: the campaign store is in use by another process (DuckDB could not lock it).")
    if "permission denied" in text.lower() or "read-only" in text.lower():
        return InputError(f"{path}: the campaign store cannot be opened for writing: permission denied.")
    return InputError(f"{path}: the campaign store is damaged or not a DuckDB store: {text}")


class CampaignStore:
    """A DuckDB file holding a campaign's applications and events (see the module docstring).

    Use it as a context manager, which closes the connection.

    Parameters
    ----------
    path : str or Path
        The DuckDB file; created with empty ``applications`` and ``events`` tables when new.

    Raises
    ------
    InputError
        If DuckDB is not installed (the ``campaign`` extra), or ``path`` is not a squealkit
        campaign store: a folder, an empty, damaged or non-DuckDB file (a SQLite file is
        recognised and refused before DuckDB sees it), a store holding other tables or
        columns, a read-only store or one in use by another process. The message is one line
        naming the file; the file is left as it was.
    """

    def __init__(self, path: str | Path):
        duckdb = require("duckdb", "A campaign store")
        self.path = Path(path)
        self._limited = False
        existed = self.path.exists()
        if existed:
            _check_file(self.path)
        try:
            # no extension is fetched or loaded for a file DuckDB does not recognise (a SQLite file
            # would make it download sqlite_scanner)
            self.con = duckdb.connect(str(self.path), config={"autoinstall_known_extensions": False,
                                                               "autoload_known_extensions": False})
        except duckdb.Error as e:
            raise _store_error(self.path, e) from e
        try:
            if existed:
                self._check_schema()
            self._create()
        except (duckdb.Error, InputError) as e:
            self.con.close()
            raise e if isinstance(e, InputError) else _store_error(self.path, e) from e

    def _check_schema(self) -> None:
        """An existing store holds only squealkit's tables and view, with their columns; all of it readable."""
        objects = dict(self.con.execute(
            "SELECT table_name, table_type FROM information_schema.tables WHERE table_schema = 'main'").fetchall())
        ours = {"applications": "BASE TABLE", "events": "BASE TABLE", "squeal": "VIEW"}
        other = sorted(set(objects) - set(ours))
        if other:
            raise InputError(f"{self.path}: not a squealkit campaign store: it holds other tables or views "
                             f"({', '.join(other)}); give another --out.")
        for name, kind in objects.items():
            if kind != ours[name]:
                raise InputError(f"{self.path}: not a squealkit campaign store: {name!r} is a "
                                 f"{kind.lower()}, not a {ours[name].lower()}.")
        for table, spec in (("applications", APPLICATION_COLUMNS), ("events", EVENT_COLUMNS)):
            if table not in objects:
                continue
            cols = dict(self.con.execute("SELECT column_name, data_type FROM information_schema.columns "
                                         "WHERE table_schema = 'main' AND table_name = ?", [table]).fetchall())
            want = {k: v.split()[0] for k, v in spec.items()}
            # a store written before status, or before the matrix's mu column
            optional = {"status", "mu"} if table == "applications" else set()
            wrong = sorted(k for k in set(cols) | set(want)
                           if cols.get(k) != want.get(k) and not (k in optional and k not in cols))
            if wrong:
                raise InputError(f"{self.path}: not a squealkit campaign store: table {table!r} has other "
                                 f"columns ({', '.join(wrong[:5])}{', ...' if len(wrong) > 5 else ''}).")
            self.con.execute(f"SELECT * FROM {table}").fetchall()  # every block read: a damaged file says so now

    def _create(self) -> None:
        cols = ", ".join(f"{k} {v}" for k, v in APPLICATION_COLUMNS.items())
        self.con.execute(f"CREATE TABLE IF NOT EXISTS applications ({cols})")
        # a store written before the status column: add it, derived from error
        self.con.execute("ALTER TABLE applications ADD COLUMN IF NOT EXISTS status VARCHAR")
        self.con.execute("UPDATE applications SET status = CASE WHEN error IS NULL THEN 'ok' ELSE 'failed' END "
                         "WHERE status IS NULL")
        # and before the run-out link could be unavailable (then it never was)
        self.con.execute("ALTER TABLE applications ADD COLUMN IF NOT EXISTS runout_unavailable VARCHAR")
        # and before the matrix's mu column (the dynamometer's friction coefficient per application)
        self.con.execute("ALTER TABLE applications ADD COLUMN IF NOT EXISTS mu DOUBLE")
        cols = ", ".join(f"{k} {v}" for k, v in EVENT_COLUMNS.items())
        self.con.execute(f"CREATE TABLE IF NOT EXISTS events ({cols})")
        self.con.execute(
            "CREATE OR REPLACE VIEW squeal AS SELECT e.*, a.section, a.mode, a.pressure_bar, a.temperature_c, "
            "a.speed_kmh, a.file FROM events e JOIN applications a USING (application)")

    def close(self) -> None:
        self.con.close()

    def __enter__(self) -> CampaignStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def done(self, criteria: str) -> dict[str, tuple[int, int]]:
        """``{application: (file_size, file_mtime_ns)}`` of applications analysed with ``criteria``.

        Parameters
        ----------
        criteria : str
            The criteria's description (:meth:`SquealCriteria.describe`) they were analysed with.

        Returns
        -------
        dict of str to (int, int)
            File size [bytes] and modification time [ns] of each application's file at analysis.
        """
        rows = self.con.execute("SELECT application, file_size, file_mtime_ns FROM applications "
                                "WHERE criteria = ? AND error IS NULL", [criteria]).fetchall()
        return {a: (s, m) for a, s, m in rows}

    def put(self, app: Mapping[str, Any], events: Sequence[Mapping[str, Any]]) -> None:
        """Replace one application's rows, in one transaction (``status`` follows ``error``).

        Parameters
        ----------
        app : mapping
            The application's row (keys: :data:`APPLICATION_COLUMNS`).
        events : sequence of mapping
            Its squeal events (keys: :data:`EVENT_COLUMNS`).
        """
        self.put_many([(app, events)])

    def put_many(self, results: Sequence[tuple[Mapping[str, Any], Sequence[Mapping[str, Any]]]]) -> None:
        """Replace several applications' rows in one transaction: all of them or none.

        A transaction per application costs about 5 ms; a campaign's client stores its
        results in batches this way.

        Parameters
        ----------
        results : sequence of (app, events)
            As for :meth:`put`.
        """
        if not results:
            return
        import pandas as pd

        a_cols, e_cols = list(APPLICATION_COLUMNS), list(EVENT_COLUMNS)
        apps = pd.DataFrame([[a.get(c) for c in a_cols] for a, _ in results], columns=a_cols, dtype=object)
        apps["status"] = ["ok" if a.get("error") is None else "failed" for a, _ in results]
        events = pd.DataFrame([[e.get(c) for c in e_cols] for _, evs in results for e in evs], columns=e_cols,
                              dtype=object)
        self.con.register("new_apps", apps)
        self.con.register("new_events", events)
        self.con.execute("BEGIN TRANSACTION")
        try:  # (DuckDB casts the object columns to the tables' types)
            self.con.execute("DELETE FROM events WHERE application IN (SELECT application FROM new_apps)")
            self.con.execute("DELETE FROM applications WHERE application IN (SELECT application FROM new_apps)")
            self.con.execute(f"INSERT INTO applications ({', '.join(a_cols)}) SELECT {', '.join(a_cols)} FROM new_apps")
            self.con.execute(f"INSERT INTO events ({', '.join(e_cols)}) SELECT {', '.join(e_cols)} FROM new_events")
            self.con.execute("COMMIT")
        except Exception:
            self.con.execute("ROLLBACK")
            raise
        finally:
            self.con.unregister("new_apps")
            self.con.unregister("new_events")

    def limit_to(self, applications: Sequence[str]) -> None:
        """Let ``{in_matrix}`` in :meth:`query` select only these applications (the current matrix's).

        Rows of applications no longer in the matrix stay in the file but out of the summary
        and the report (an application taken out of the matrix no longer counts, nor fails).

        Parameters
        ----------
        applications : sequence of str
            The application ids of the current test matrix.
        """
        self.con.execute("CREATE OR REPLACE TEMP TABLE in_matrix (application VARCHAR)")
        if applications:
            self.con.executemany("INSERT INTO in_matrix VALUES (?)", [[a] for a in applications])
        self._limited = True

    def query(self, sql: str, params: Sequence[Any] = ()):
        """Rows of a SQL query as a pandas DataFrame.

        ``{in_matrix}`` in ``sql`` is a condition on ``application``: true for the applications
        given to :meth:`limit_to`, for every one if it was not called.

        Parameters
        ----------
        sql : str
            The query, over the tables ``applications`` and ``events`` and the view ``squeal``.
        params : sequence, optional
            Values of its ``?`` placeholders.

        Returns
        -------
        pandas.DataFrame
        """
        cond = "application IN (SELECT application FROM in_matrix)" if self._limited else "TRUE"
        return self.con.execute(sql.replace("{in_matrix}", cond), list(params)).df()
