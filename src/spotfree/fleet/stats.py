"""Fleet statistics by rider group, vehicle and place, by DuckDB over the Parquet output of ``fleet process``.

For each grouping (:data:`GROUPS`) and each of its groups:

* ``rides``, ``km`` (sum of the rides' GPS distance), ``hours`` (measured time);
* ``braking_per_km`` = braking events / km, ``sudden_per_km`` = sudden stops / km, and the sudden-stop rate
  ``sudden_rate`` = sudden stops / braking events (a sudden stop is also a braking event);
* speed distribution over moving samples (speed above :data:`~spotfree.fleet.process.MOVING` m/s): quantiles
  ``speed_p05 .. speed_p95`` (m/s);
* deceleration distribution over braking events (each event's peak deceleration, m/s^2): ``decel_p05 ..
  decel_p95``.

:func:`fleet_stats` writes ``by_<grouping>.csv`` and ``by_<grouping>.png`` (bars of the rates, box plots of
the two distributions drawn from the quantiles: whiskers at 5 and 95 %) and ``stats.md`` with every table.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from spotfree.errors import InputError
from spotfree.fleet.process import MOVING

GROUPS = ("age_band", "gender", "skill", "vehicle", "place")
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)


def _source(out: Path, table: str) -> str:
    files = list((out / table).glob("*/*/*.parquet"))
    if not files:
        raise InputError(f"{out}: no {table} results; run 'spotfree fleet process' into this folder first")
    pattern = (out / table / "*" / "*" / "*.parquet").as_posix().replace("'", "''")
    return f"read_parquet('{pattern}', hive_partitioning = false, union_by_name = true)"


def _quantiles(column: str, name: str) -> str:
    return ", ".join(f"quantile_cont({column}, {q}) AS {name}_p{round(q * 100):02d}" for q in QUANTILES)


def group_stats(out: str | Path, group: str) -> pd.DataFrame:
    """The statistics of one grouping (see the module docstring), one row per group, ordered by group."""
    import duckdb

    if group not in GROUPS:
        raise InputError(f"fleet stats: unknown grouping {group!r}; use one of {', '.join(GROUPS)}")
    out = Path(out)
    rides, samples, events = (_source(out, t) for t in ("rides", "samples", "events"))
    sql = f"""
        WITH r AS (SELECT * FROM {rides}),
        totals AS (
            SELECT coalesce(CAST({group} AS VARCHAR), 'unknown') AS grp, count(*) AS rides,
                   sum(distance_m) / 1000 AS km, sum(duration_s) / 3600 AS hours,
                   sum(braking_events) AS braking_events, sum(sudden_stops) AS sudden_stops
            FROM r GROUP BY grp),
        speed AS (
            SELECT coalesce(CAST(r.{group} AS VARCHAR), 'unknown') AS grp, {_quantiles('s.speed', 'speed')}
            FROM {samples} s JOIN r USING (ride_id) WHERE s.speed > {MOVING} GROUP BY grp),
        decel AS (
            SELECT coalesce(CAST(r.{group} AS VARCHAR), 'unknown') AS grp, {_quantiles('e.peak_decel', 'decel')}
            FROM {events} e JOIN r USING (ride_id) WHERE e.kind = 'braking' GROUP BY grp)
        SELECT totals.grp AS {group}, rides, km, hours,
               braking_events / nullif(km, 0) AS braking_per_km, sudden_stops / nullif(km, 0) AS sudden_per_km,
               sudden_stops / nullif(braking_events, 0) AS sudden_rate, braking_events, sudden_stops,
               speed.* EXCLUDE (grp), decel.* EXCLUDE (grp)
        FROM totals LEFT JOIN speed USING (grp) LEFT JOIN decel USING (grp) ORDER BY totals.grp
    """
    return duckdb.sql(sql).df()


def plot_group(table: pd.DataFrame, group: str, path: str | Path) -> None:
    """Rates per km as bars, speed and deceleration distributions as box plots (quantiles), one PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = table[group].astype(str).tolist()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    x = range(len(names))
    axes[0].bar([k - 0.2 for k in x], table["braking_per_km"], 0.4, label="braking events")
    axes[0].bar([k + 0.2 for k in x], table["sudden_per_km"], 0.4, label="sudden stops")
    axes[0].set(ylabel="events per km", title=f"braking by {group}")
    axes[0].set_xticks(list(x), names, rotation=30, ha="right")
    axes[0].legend()
    for ax, prefix, unit in ((axes[1], "speed", "speed when moving, m/s"),
                             (axes[2], "decel", "peak deceleration of braking events, m/s²")):
        stats = [{"label": n, "whislo": row[f"{prefix}_p05"], "q1": row[f"{prefix}_p25"],
                  "med": row[f"{prefix}_p50"], "q3": row[f"{prefix}_p75"], "whishi": row[f"{prefix}_p95"]}
                 for n, (_, row) in zip(names, table.iterrows())]
        ax.bxp(stats, showfliers=False)
        ax.set(ylabel=unit, title=f"{prefix} by {group} (5-25-50-75-95 %)")
        ax.tick_params(axis="x", labelrotation=30)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def markdown(table: pd.DataFrame) -> str:
    """A Markdown table of ``table``, numbers to 3 significant digits."""
    cells = [[f"{v:.3g}" if isinstance(v, float) else str(v) for v in row] for row in table.itertuples(index=False)]
    return "\n".join("| " + " | ".join(r) + " |" for r in [list(table.columns), ["---"] * table.shape[1], *cells])


def fleet_stats(out: str | Path, folder: str | Path, groups: tuple[str, ...] = GROUPS) -> dict[str, pd.DataFrame]:
    """Write the statistics of every grouping into ``folder`` (see the module docstring); returns the tables."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    tables, lines = {}, ["# Fleet statistics", "", f"From `{out}`; rates per km of GPS distance.", ""]
    for group in groups:
        table = group_stats(out, group)
        table.to_csv(folder / f"by_{group}.csv", index=False)
        plot_group(table, group, folder / f"by_{group}.png")
        tables[group] = table
        lines += [f"## By {group}", "", markdown(table), "",
                  f"![by {group}](by_{group}.png)", ""]
    (folder / "stats.md").write_text("\n".join(lines), encoding="utf-8")
    return tables
